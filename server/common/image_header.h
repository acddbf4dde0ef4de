#ifndef WAYMARK_SERVER_COMMON_IMAGE_HEADER_H_
#define WAYMARK_SERVER_COMMON_IMAGE_HEADER_H_

// The size a JPEG or PNG claims in its header, read before anything is decoded: a decoder
// allocates what the header claims, so a 1 MB PNG of 20000 x 20000 zero pixels made the server
// allocate 1.2 GB before its size check ran (issue 21). Callers refuse an image that claims more
// than they take, and bytes whose header cannot be read, before they decode.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "absl/strings/string_view.h"

namespace waymark {

struct ImageHeader {
  int width = 0;
  int height = 0;
  bool png = false;
  int png_bit_depth = 0;
  int png_colour_type = -1;  // 0 gray, 2 RGB, 3 palette, 4 gray + alpha, 6 RGBA
};

namespace image_header_internal {
inline uint32_t BigEndian(absl::string_view s, size_t at, int bytes) {
  uint32_t value = 0;
  for (int i = 0; i < bytes; ++i) value = (value << 8) | static_cast<unsigned char>(s[at + i]);
  return value;
}
}  // namespace image_header_internal

// Size (and PNG pixel format) from the header; nullopt when the bytes are neither a PNG nor a
// JPEG with a frame header.
inline std::optional<ImageHeader> ReadImageHeader(absl::string_view bytes) {
  using image_header_internal::BigEndian;
  static const char kPng[] = "\x89PNG\r\n\x1a\n";
  ImageHeader header;
  if (bytes.size() >= 26 && bytes.substr(0, 8) == absl::string_view(kPng, 8) &&
      bytes.substr(12, 4) == "IHDR") {
    header.png = true;
    header.width = static_cast<int>(std::min<uint32_t>(BigEndian(bytes, 16, 4), 1u << 30));
    header.height = static_cast<int>(std::min<uint32_t>(BigEndian(bytes, 20, 4), 1u << 30));
    header.png_bit_depth = static_cast<unsigned char>(bytes[24]);
    header.png_colour_type = static_cast<unsigned char>(bytes[25]);
    return header;
  }
  if (bytes.size() < 4 || static_cast<unsigned char>(bytes[0]) != 0xFF ||
      static_cast<unsigned char>(bytes[1]) != 0xD8) {
    return std::nullopt;
  }
  // JPEG: walk the marker segments to the first start-of-frame (SOF0-SOF15 but DHT C4, JPG C8,
  // DAC CC), whose payload is precision, height, width.
  size_t at = 2;
  while (at + 4 <= bytes.size()) {
    if (static_cast<unsigned char>(bytes[at]) != 0xFF) return std::nullopt;
    const unsigned char marker = static_cast<unsigned char>(bytes[at + 1]);
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length
      at += 2;
      continue;
    }
    const uint32_t length = BigEndian(bytes, at + 2, 2);
    if (length < 2) return std::nullopt;
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      if (at + 9 > bytes.size()) return std::nullopt;
      header.height = static_cast<int>(BigEndian(bytes, at + 5, 2));
      header.width = static_cast<int>(BigEndian(bytes, at + 7, 2));
      return header;
    }
    if (marker == 0xDA || marker == 0xD9) return std::nullopt;  // scan data before any frame
    at += 2 + length;
  }
  return std::nullopt;
}

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_IMAGE_HEADER_H_
