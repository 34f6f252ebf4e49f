#include "fabrica/render/image.hpp"

#include <stb_image.h>
#include <zlib.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <ostream>
#include <string>
#include <vector>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"

namespace fabrica::render {

namespace {

void put_u32(std::vector<unsigned char>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<unsigned char>(v >> shift));
}

/// One PNG chunk: length, type, data, CRC-32 of type and data.
void write_chunk(std::ostream& out, const char (&type)[5], const unsigned char* data,
                 std::size_t size) {
  std::vector<unsigned char> head;
  put_u32(head, static_cast<std::uint32_t>(size));
  head.insert(head.end(), type, type + 4);
  uLong crc = crc32(0L, head.data() + 4, 4);
  if (size > 0) crc = crc32(crc, data, static_cast<uInt>(size));
  std::vector<unsigned char> tail;
  put_u32(tail, static_cast<std::uint32_t>(crc));
  out.write(reinterpret_cast<const char*>(head.data()), static_cast<std::streamsize>(head.size()));
  if (size > 0) out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.write(reinterpret_cast<const char*>(tail.data()), 4);
}

}  // namespace

// PNG (RFC 2083 / ISO 15948): 8-bit RGBA, every row with the "Up" filter
// (the difference to the row above: illustrations are mostly flat areas and
// long edges, which it turns into runs of zeros) and zlib's deflate at level
// 3. Measured on 2048² renders: a third of stb_image_write's time at its
// default level 8 and a fifth smaller files (docs/PERFORMANCE.md, "fabrica
// batch"). The bytes depend only on the pixels.
void write_png(const Image& image, const std::filesystem::path& path) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
    throw Error(ErrorKind::internal, "write_png: inconsistent image for " + path.string());
  const std::size_t stride = static_cast<std::size_t>(image.width) * 4;
  const auto height = static_cast<std::size_t>(image.height);
  std::vector<unsigned char> filtered((stride + 1) * height);
  for (std::size_t y = 0; y < height; ++y) {
    unsigned char* row = &filtered[y * (stride + 1)];
    const unsigned char* now = image.rgba.data() + y * stride;
    row[0] = y == 0 ? 0 : 2;  // none for the first row, else Up
    if (y == 0) {
      std::copy(now, now + stride, row + 1);
      continue;
    }
    const unsigned char* above = now - stride;
    for (std::size_t x = 0; x < stride; ++x)
      row[x + 1] = static_cast<unsigned char>(now[x] - above[x]);
  }
  z_stream z{};
  if (deflateInit2(&z, 3, Z_DEFLATED, 15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw Error(ErrorKind::internal, "write_png: zlib cannot start for " + path.string());
  std::vector<unsigned char> compressed(deflateBound(&z, static_cast<uLong>(filtered.size())));
  z.next_in = filtered.data();
  z.avail_in = static_cast<uInt>(filtered.size());
  z.next_out = compressed.data();
  z.avail_out = static_cast<uInt>(compressed.size());
  const int done = deflate(&z, Z_FINISH);
  compressed.resize(z.total_out);
  deflateEnd(&z);
  if (done != Z_STREAM_END)
    throw OutputError("cannot encode PNG " + path.string() + " (zlib: " + std::to_string(done) +
                      ")");

  std::vector<unsigned char> header;
  put_u32(header, static_cast<std::uint32_t>(image.width));
  put_u32(header, static_cast<std::uint32_t>(image.height));
  header.insert(header.end(),
                {8, 6, 0, 0, 0});  // 8 bits, RGBA, deflate, adaptive filters, no interlace
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        static const unsigned char signature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
        out.write(reinterpret_cast<const char*>(signature), 8);
        write_chunk(out, "IHDR", header.data(), header.size());
        // IDAT chunks of at most 1 MiB (any split is valid; fixed for identical bytes).
        constexpr std::size_t kChunk = 1u << 20;
        for (std::size_t at = 0; at < compressed.size(); at += kChunk)
          write_chunk(out, "IDAT", compressed.data() + at,
                      std::min(kChunk, compressed.size() - at));
        write_chunk(out, "IEND", nullptr, 0);
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
