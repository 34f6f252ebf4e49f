#include "fabrica/render/image.hpp"

#include <stb_image.h>
#include <stb_image_write.h>

#include <cstdlib>
#include <ostream>
#include <string>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"

namespace fabrica::render {

void write_png(const Image& image, const std::filesystem::path& path) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
    throw Error(ErrorKind::internal, "write_png: inconsistent image for " + path.string());
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        auto sink = [](void* context, void* data, int size) {
          static_cast<std::ostream*>(context)->write(static_cast<const char*>(data), size);
        };
        if (stbi_write_png_to_func(sink, &out, image.width, image.height, 4, image.rgba.data(),
                                   image.width * 4) == 0)
          throw OutputError("cannot encode PNG " + path.string());
      },
      true);
}

Image read_png(const std::filesystem::path& path) {
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &w, &h, &n, 4);
  if (data == nullptr) {
    const char* reason = stbi_failure_reason();
    throw InputError("cannot read image " + path.string() + ": " +
                     (reason != nullptr ? reason : "unknown error"));
  }
  Image image(w, h);
  std::copy(data, data + image.rgba.size(), image.rgba.begin());
  stbi_image_free(data);
  return image;
}

ImageDifference compare_images(const Image& a, const Image& b, int tolerance) {
  ImageDifference d;
  d.same_size = a.width == b.width && a.height == b.height && a.rgba.size() == b.rgba.size();
  if (!d.same_size) return d;
  std::size_t over = 0;
  double sum = 0.0;
  const std::size_t pixels = a.rgba.size() / 4;
  for (std::size_t p = 0; p < pixels; ++p) {
    int worst = 0;
    for (int c = 0; c < 4; ++c) {
      const int diff = std::abs(int(a.rgba[p * 4 + c]) - int(b.rgba[p * 4 + c]));
      worst = std::max(worst, diff);
      sum += diff;
    }
    d.max_abs = std::max(d.max_abs, worst);
    if (worst > tolerance) ++over;
  }
  d.mean_abs = pixels ? sum / double(pixels * 4) : 0.0;
  d.fraction_over = pixels ? double(over) / double(pixels) : 0.0;
  return d;
}

}  // namespace fabrica::render
