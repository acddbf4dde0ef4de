#include "client/datasets/ros_map_yaml.h"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace waymark::cli {
namespace {

struct Entry {
  std::string value;
  int line = 0;
};
using Entries = std::map<std::string, Entry>;

// The line without a '#' comment: one at its start or after whitespace, outside a quoted scalar
// (YAML's rule: "a#b" is a value, and so is "'a # b'"). A quote opens a scalar only where a value
// starts (after whitespace or ':'), so the apostrophe of "bob's" opens nothing.
absl::string_view WithoutComment(absl::string_view line) {
  char quote = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    const bool token_start = i == 0 || line[i - 1] == ':' ||
                             absl::ascii_isspace(static_cast<unsigned char>(line[i - 1]));
    if (quote != 0) {
      if (c == quote) quote = 0;
    } else if ((c == '"' || c == '\'') && token_start) {
      quote = c;
    } else if (c == '#' && token_start) {
      return line.substr(0, i);
    }
  }
  return line;
}

absl::string_view Unquoted(absl::string_view value) {
  if (value.size() >= 2 && (value.front() == '"' || value.front() == '\'') &&
      value.back() == value.front()) {
    return value.substr(1, value.size() - 2);
  }
  return value;
}

absl::StatusOr<Entries> ParseEntries(absl::string_view text, const std::string& name) {
  Entries entries;
  int number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++number;
    line = absl::StripAsciiWhitespace(WithoutComment(absl::StripSuffix(line, "\r")));
    if (line.empty() || line == "---" || line == "...") continue;  // YAML document markers
    const size_t colon = line.find(':');
    const absl::string_view key =
        colon == absl::string_view::npos ? "" : absl::StripAsciiWhitespace(line.substr(0, colon));
    if (key.empty()) {
      return absl::InvalidArgumentError(fmt::format("{}: line {}: expected 'key: value', got '{}'",
                                                    name, number, std::string(line)));
    }
    const absl::string_view value = Unquoted(absl::StripAsciiWhitespace(line.substr(colon + 1)));
    auto [it, inserted] = entries.try_emplace(std::string(key), Entry{std::string(value), number});
    if (!inserted) {
      return absl::InvalidArgumentError(
          fmt::format("{}: line {}: duplicate key '{}' (first on line {})", name, number,
                      std::string(key), it->second.line));
    }
  }
  return entries;
}

absl::StatusOr<const Entry*> Required(const Entries& entries, absl::string_view key,
                                      const std::string& name) {
  auto it = entries.find(std::string(key));
  if (it == entries.end()) {
    return absl::InvalidArgumentError(fmt::format("{}: missing key '{}'", name, std::string(key)));
  }
  return &it->second;
}

std::optional<double> FiniteNumber(absl::string_view text) {
  double value = 0;
  if (!absl::SimpleAtod(absl::StripAsciiWhitespace(text), &value) || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

absl::Status BadValue(const std::string& name, absl::string_view key, const Entry& entry,
                      absl::string_view expected) {
  return absl::InvalidArgumentError(fmt::format("{}: line {}: '{}': {}, got '{}'", name, entry.line,
                                                std::string(key), std::string(expected),
                                                entry.value));
}

absl::StatusOr<double> Number(const Entries& entries, absl::string_view key,
                              const std::string& name) {
  absl::StatusOr<const Entry*> entry = Required(entries, key, name);
  if (!entry.ok()) return entry.status();
  std::optional<double> value = FiniteNumber((*entry)->value);
  if (!value) return BadValue(name, key, **entry, "bad number");
  return *value;
}

// [x, y, yaw]
absl::Status ReadOrigin(const Entries& entries, const std::string& name, RosMapMetadata& metadata) {
  absl::StatusOr<const Entry*> entry = Required(entries, "origin", name);
  if (!entry.ok()) return entry.status();
  absl::string_view list = (*entry)->value;
  const bool bracketed = absl::ConsumePrefix(&list, "[") && absl::ConsumeSuffix(&list, "]");
  const std::vector<absl::string_view> items = absl::StrSplit(list, ',');
  std::vector<double> values;
  for (absl::string_view item : items) {
    if (std::optional<double> value = FiniteNumber(item)) values.push_back(*value);
  }
  if (!bracketed || items.size() != 3 || values.size() != 3) {
    return BadValue(name, "origin", **entry, "expected [x, y, yaw] (three numbers)");
  }
  metadata.origin_x = values[0];
  metadata.origin_y = values[1];
  metadata.origin_yaw = values[2];
  return absl::OkStatus();
}

absl::Status ReadNegate(const Entries& entries, const std::string& name, RosMapMetadata& metadata) {
  absl::StatusOr<const Entry*> entry = Required(entries, "negate", name);
  if (!entry.ok()) return entry.status();
  const std::string value = absl::AsciiStrToLower((*entry)->value);
  if (value == "0" || value == "false") {
    metadata.negate = false;
  } else if (value == "1" || value == "true") {
    metadata.negate = true;
  } else {
    return BadValue(name, "negate", **entry, "expected 0 or 1");
  }
  return absl::OkStatus();
}

absl::Status ReadMode(const Entries& entries, const std::string& name, RosMapMetadata& metadata) {
  auto it = entries.find("mode");
  if (it == entries.end()) return absl::OkStatus();  // map_server's default: trinary
  for (RosMapMode mode : {RosMapMode::kTrinary, RosMapMode::kScale, RosMapMode::kRaw}) {
    if (it->second.value == RosMapModeName(mode)) {
      metadata.mode = mode;
      return absl::OkStatus();
    }
  }
  return BadValue(name, "mode", it->second, "expected trinary, scale or raw");
}

absl::Status CheckThresholds(const Entries& entries, const std::string& name,
                             const RosMapMetadata& metadata) {
  for (auto [key, value] :
       {std::pair<const char*, double>{"occupied_thresh", metadata.occupied_thresh},
        std::pair<const char*, double>{"free_thresh", metadata.free_thresh}}) {
    if (value < 0 || value > 1) {
      return BadValue(name, key, entries.find(std::string(key))->second,
                      "expected a number in [0, 1]");
    }
  }
  if (!(metadata.free_thresh < metadata.occupied_thresh)) {
    return absl::InvalidArgumentError(
        fmt::format("{}: free_thresh {} must be below occupied_thresh {}", name,
                    metadata.free_thresh, metadata.occupied_thresh));
  }
  return absl::OkStatus();
}

// A number as YAML float: always with a decimal point or exponent ("0.0", not "0").
std::string YamlNumber(double value) {
  std::string text = fmt::format("{}", value);
  if (text.find_first_of(".eEn") == std::string::npos) text += ".0";
  return text;
}

}  // namespace

const char* RosMapModeName(RosMapMode mode) {
  switch (mode) {
    case RosMapMode::kTrinary:
      return "trinary";
    case RosMapMode::kScale:
      return "scale";
    case RosMapMode::kRaw:
      return "raw";
  }
  return "trinary";
}

absl::StatusOr<RosMapMetadata> ParseRosMapYaml(const std::string& text, const std::string& name) {
  absl::StatusOr<Entries> entries = ParseEntries(text, name);
  if (!entries.ok()) return entries.status();
  RosMapMetadata metadata;
  absl::StatusOr<const Entry*> image = Required(*entries, "image", name);
  if (!image.ok()) return image.status();
  if ((*image)->value.empty()) return BadValue(name, "image", **image, "expected a file name");
  metadata.image = (*image)->value;
  absl::StatusOr<double> resolution = Number(*entries, "resolution", name);
  if (!resolution.ok()) return resolution.status();
  if (*resolution <= 0) {
    return BadValue(name, "resolution", entries->find("resolution")->second,
                    "must be positive (m per pixel)");
  }
  metadata.resolution = *resolution;
  if (absl::Status s = ReadOrigin(*entries, name, metadata); !s.ok()) return s;
  if (absl::Status s = ReadNegate(*entries, name, metadata); !s.ok()) return s;
  absl::StatusOr<double> occupied = Number(*entries, "occupied_thresh", name);
  if (!occupied.ok()) return occupied.status();
  metadata.occupied_thresh = *occupied;
  absl::StatusOr<double> free = Number(*entries, "free_thresh", name);
  if (!free.ok()) return free.status();
  metadata.free_thresh = *free;
  if (absl::Status s = CheckThresholds(*entries, name, metadata); !s.ok()) return s;
  if (absl::Status s = ReadMode(*entries, name, metadata); !s.ok()) return s;
  return metadata;
}

std::string FormatRosMapYaml(const RosMapMetadata& metadata) {
  return fmt::format(
      "image: {}\nmode: {}\nresolution: {}\norigin: [{}, {}, {}]\nnegate: {}\n"
      "occupied_thresh: {}\nfree_thresh: {}\n",
      metadata.image, RosMapModeName(metadata.mode), YamlNumber(metadata.resolution),
      YamlNumber(metadata.origin_x), YamlNumber(metadata.origin_y), YamlNumber(metadata.origin_yaw),
      metadata.negate ? 1 : 0, YamlNumber(metadata.occupied_thresh),
      YamlNumber(metadata.free_thresh));
}

}  // namespace waymark::cli
