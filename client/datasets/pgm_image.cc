#include "client/datasets/pgm_image.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cstdint>
#include <optional>

namespace waymark::cli {
namespace {

constexpr int kMaxval = 255;

bool IsSpace(char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; }

// The first bytes of a file, printable: "P6", "\x89P".
std::string Printable(std::string_view bytes) {
  std::string out;
  for (char c : bytes) {
    const auto u = static_cast<unsigned char>(c);
    out += std::isprint(u) ? std::string(1, c) : fmt::format("\\x{:02x}", u);
  }
  return out;
}

// Whitespace-separated tokens of a PGM header or plain raster, with '#' comments (to the end of
// their line) skipped wherever they are.
class Tokens {
 public:
  Tokens(std::string_view bytes, size_t at) : bytes_(bytes), at_(at) {}

  // The next token, or nullopt at the end of the bytes.
  std::optional<std::string_view> Next() {
    while (at_ < bytes_.size()) {
      if (IsSpace(bytes_[at_])) {
        ++at_;
      } else if (bytes_[at_] == '#') {
        while (at_ < bytes_.size() && bytes_[at_] != '\n' && bytes_[at_] != '\r') ++at_;
      } else {
        break;
      }
    }
    if (at_ >= bytes_.size()) return std::nullopt;
    const size_t start = at_;
    while (at_ < bytes_.size() && !IsSpace(bytes_[at_]) && bytes_[at_] != '#') ++at_;
    return bytes_.substr(start, at_ - start);
  }

  // Just after the last token read.
  size_t position() const { return at_; }

 private:
  std::string_view bytes_;
  size_t at_;
};

// A whole token as a non-negative integer (digits only).
std::optional<int64_t> Digits(std::string_view token) {
  int64_t value = 0;
  const char* end = token.data() + token.size();
  const auto [stop, error] = std::from_chars(token.data(), end, value);
  if (token.empty() || token[0] == '-' || error != std::errc() || stop != end) return std::nullopt;
  return value;
}

// A header number (width, height, maxval).
absl::StatusOr<int64_t> HeaderNumber(Tokens& tokens, std::string_view what, std::string_view name) {
  const std::optional<std::string_view> token = tokens.Next();
  if (!token) {
    return absl::InvalidArgumentError(
        fmt::format("{}: truncated header: the file ends before the {}", name, what));
  }
  const std::optional<int64_t> value = Digits(*token);
  if (!value || *value > INT32_MAX) {
    return absl::InvalidArgumentError(
        fmt::format("{}: bad {} '{}' in the header", name, what, Printable(*token)));
  }
  return *value;
}

absl::Status SizeMismatch(std::string_view name, const GrayImage& image, std::string_view what) {
  return absl::InvalidArgumentError(fmt::format(
      "{}: image size mismatch: the header says {} x {} ({} pixels) but more {} follow", name,
      image.width, image.height, static_cast<int64_t>(image.width) * image.height, what));
}

absl::Status ReadBinaryRaster(std::string_view bytes, size_t at, std::string_view name,
                              GrayImage& image) {
  const auto expected = static_cast<size_t>(image.width) * static_cast<size_t>(image.height);
  // Exactly one whitespace character separates maxval from the raster.
  const std::string_view raster = at < bytes.size() ? bytes.substr(at + 1) : std::string_view();
  if (raster.size() < expected) {
    return absl::InvalidArgumentError(
        fmt::format("{}: truncated pixel data: {} of {} bytes ({} x {})", name, raster.size(),
                    expected, image.width, image.height));
  }
  if (raster.size() > expected) {
    return SizeMismatch(name, image, fmt::format("bytes ({})", raster.size()));
  }
  image.pixels.assign(raster.begin(), raster.end());
  return absl::OkStatus();
}

absl::Status ReadPlainRaster(Tokens& tokens, std::string_view name, GrayImage& image) {
  const auto expected = static_cast<size_t>(image.width) * static_cast<size_t>(image.height);
  while (std::optional<std::string_view> token = tokens.Next()) {
    if (image.pixels.size() == expected) return SizeMismatch(name, image, "pixel values");
    const std::optional<int64_t> value = Digits(*token);
    if (!value) {
      return absl::InvalidArgumentError(fmt::format("{}: bad pixel value '{}' (pixel {})", name,
                                                    Printable(*token), image.pixels.size()));
    }
    if (*value > kMaxval) {
      return absl::InvalidArgumentError(fmt::format("{}: pixel value {} above maxval {} (pixel {})",
                                                    name, *value, kMaxval, image.pixels.size()));
    }
    image.pixels.push_back(static_cast<uint8_t>(*value));
  }
  if (image.pixels.size() < expected) {
    return absl::InvalidArgumentError(
        fmt::format("{}: truncated pixel data: {} of {} pixel values ({} x {})", name,
                    image.pixels.size(), expected, image.width, image.height));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<GrayImage> ParsePgm(std::string_view bytes, std::string_view name) {
  const std::string_view magic = bytes.substr(0, 2);
  const bool binary = magic == "P5";
  if (!binary && magic != "P2") {
    return absl::InvalidArgumentError(
        fmt::format("{}: not a PGM image: it starts with '{}', not P5 (binary) or P2 (plain)", name,
                    Printable(magic)));
  }
  Tokens tokens(bytes, 2);
  GrayImage image;
  for (auto [what, target] : {std::pair<const char*, int*>{"width", &image.width},
                              std::pair<const char*, int*>{"height", &image.height}}) {
    absl::StatusOr<int64_t> value = HeaderNumber(tokens, what, name);
    if (!value.ok()) return value.status();
    if (*value == 0) {
      return absl::InvalidArgumentError(
          fmt::format("{}: the image has no pixels ({} 0 in the header)", name, what));
    }
    *target = static_cast<int>(*value);
  }
  absl::StatusOr<int64_t> maxval = HeaderNumber(tokens, "maxval", name);
  if (!maxval.ok()) return maxval.status();
  if (*maxval != kMaxval) {
    return absl::InvalidArgumentError(fmt::format(
        "{}: maxval {} in the header: only 8-bit images with maxval 255 are read", name, *maxval));
  }
  const absl::Status raster = binary ? ReadBinaryRaster(bytes, tokens.position(), name, image)
                                     : ReadPlainRaster(tokens, name, image);
  if (!raster.ok()) return raster;
  return image;
}

std::string EncodePgm(const GrayImage& image, std::string_view comment) {
  std::string out = "P5\n";
  if (!comment.empty()) out += fmt::format("# {}\n", comment);
  out += fmt::format("{} {}\n{}\n", image.width, image.height, kMaxval);
  out.append(image.pixels.begin(), image.pixels.end());
  return out;
}

}  // namespace waymark::cli
