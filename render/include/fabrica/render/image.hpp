// Image: 8-bit RGBA pixels, top row first, straight (not premultiplied)
// alpha, as written to PNG. Colours are stored as computed (no sRGB
// conversion): a Lambert value of 0.5 is stored as 128.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

namespace fabrica::render {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  ///< width*height*4, row y = 0 is the top

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgba(static_cast<std::size_t>(w) * h * 4, 0) {}
  std::uint8_t* pixel(int x, int y) {
    return rgba.data() + (static_cast<std::size_t>(y) * width + x) * 4;
  }
  const std::uint8_t* pixel(int x, int y) const {
    return rgba.data() + (static_cast<std::size_t>(y) * width + x) * 4;
  }
};

/// Writes a PNG atomically (OutputError naming the file on failure).
void write_png(const Image& image, const std::filesystem::path& path);
/// Reads a PNG as RGBA (InputError naming the file on failure).
Image read_png(const std::filesystem::path& path);

/// Per-channel comparison of two images of the same size.
struct ImageDifference {
  bool same_size = false;
  int max_abs = 0;             ///< largest |a-b| over all channels (0..255)
  double mean_abs = 0.0;       ///< mean |a-b| over all channels
  double fraction_over = 0.0;  ///< fraction of pixels with some channel differing by > tolerance
};
ImageDifference compare_images(const Image& a, const Image& b, int tolerance);

}  // namespace fabrica::render
