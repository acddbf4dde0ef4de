#ifndef WAYMARK_CLIENT_DATASETS_PGM_IMAGE_H_
#define WAYMARK_CLIENT_DATASETS_PGM_IMAGE_H_

// 8-bit grey images in the Netpbm PGM format, the image of a ROS map_server map: binary (P5) and
// plain (P2), maxval 255, '#' comments in the header. Parsed by hand rather than through OpenCV so
// that a bad file says what is wrong with it (OpenCV's reader only says it could not decode).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::cli {

// Row-major, first row = the top of the picture (PGM order).
struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;

  uint8_t At(int column, int row) const {
    return pixels[static_cast<size_t>(row) * static_cast<size_t>(width) + column];
  }
};

// The image in `bytes` (the contents of the file `name`, which the errors name): INVALID_ARGUMENT
// for a wrong magic number, a bad or missing header number, a maxval other than 255, a zero
// size, truncated pixel data, or more pixel data than the header's size.
absl::StatusOr<GrayImage> ParsePgm(std::string_view bytes, std::string_view name);

// The binary (P5) file of `image`, with `comment` (one line, may be empty) in its header.
std::string EncodePgm(const GrayImage& image, std::string_view comment = {});

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_PGM_IMAGE_H_
