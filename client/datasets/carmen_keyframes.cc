#include "client/datasets/carmen_keyframes.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::adapters {
namespace {

// The ranges as centimetres, as a byte string usable as a hash key. Rounding is what makes "4.1"
// (corrected log) and "4.10" (raw log) the same reading.
std::string RangesKey(const std::vector<float>& ranges) {
  std::string key;
  key.reserve(ranges.size() * sizeof(int32_t));
  for (float r : ranges) {
    const int32_t cm = static_cast<int32_t>(std::llround(static_cast<double>(r) * 100.0));
    key.append(reinterpret_cast<const char*>(&cm), sizeof(cm));
  }
  return key;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  return values[mid];
}

// "%.4f" without trailing zeros (and without a trailing point): 4.1 -> "4.1", 81.91 -> "81.91".
std::string ShortNumber(double value) {
  std::string text = absl::StrFormat("%.4f", value);
  while (!text.empty() && text.back() == '0') text.pop_back();
  if (!text.empty() && text.back() == '.') text.pop_back();
  if (text == "-0") text = "0";
  return text;
}

}  // namespace

absl::StatusOr<std::vector<CarmenLaser>> ReadLaserLinesInFileOrder(const std::string& path) {
  CarmenLogReader::Options options;
  options.skip_malformed = false;
  auto reader = CarmenLogReader::Open(path, options);
  if (!reader.ok()) return reader.status();
  std::vector<CarmenLaser> lasers;
  CarmenRecord record;
  while (true) {
    absl::StatusOr<bool> more = (*reader)->Next(&record);
    if (!more.ok()) {
      return absl::Status(more.status().code(), absl::StrCat(path, ": ", more.status().message()));
    }
    if (!*more) break;
    if (record.type == CarmenRecord::Type::kLaser) lasers.push_back(std::move(record.laser));
  }
  return lasers;
}

std::string KeyframeStampSourceName(KeyframeStampSource source) {
  switch (source) {
    case KeyframeStampSource::kLog:
      return "log";
    case KeyframeStampSource::kRepaired:
      return "repaired";
    case KeyframeStampSource::kSynthesized:
      return "synthesized";
    case KeyframeStampSource::kRaw:
      return "raw";
  }
  return "unknown";
}

KeyframeStamps ChooseKeyframeStamps(const std::vector<double>& log_stamps) {
  KeyframeStamps out;
  const size_t n = log_stamps.size();
  size_t not_increasing = 0;
  bool all_finite = true;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(log_stamps[i])) all_finite = false;
    if (i > 0 && !(log_stamps[i] > log_stamps[i - 1])) ++not_increasing;
  }
  if (all_finite && not_increasing == 0) {
    out.source = KeyframeStampSource::kLog;
    out.stamps = log_stamps;
    return out;
  }
  if (all_finite && n > 1 &&
      static_cast<double>(not_increasing) <= kMaxRepairedFraction * static_cast<double>(n - 1)) {
    out.source = KeyframeStampSource::kRepaired;
    out.stamps = log_stamps;
    for (size_t i = 1; i < n; ++i) {
      // Pushed forward, not swapped: the file order is the keyframes' order, the stamps are only
      // labels here.
      if (out.stamps[i] < out.stamps[i - 1] + kRepairStepS) {
        out.stamps[i] = out.stamps[i - 1] + kRepairStepS;
        ++out.repaired;
      }
    }
    return out;
  }
  out.source = KeyframeStampSource::kSynthesized;
  out.stamps.resize(n);
  for (size_t i = 0; i < n; ++i) out.stamps[i] = kSynthesizedKeyframeIntervalS * (i + 1);
  return out;
}

RawMatch MatchKeyframesToRaw(const std::vector<CarmenLaser>& keyframes,
                             const std::vector<CarmenLaser>& raw) {
  std::unordered_map<std::string, std::vector<int>> by_ranges;  // key -> raw indices, ascending
  for (size_t i = 0; i < raw.size(); ++i) {
    by_ranges[RangesKey(raw[i].ranges)].push_back(static_cast<int>(i));
  }
  RawMatch match;
  match.raw_index.assign(keyframes.size(), -1);
  std::vector<double> offsets;
  int previous = -1;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    auto found = by_ranges.find(RangesKey(keyframes[k].ranges));
    if (found == by_ranges.end()) continue;
    const std::vector<int>& candidates = found->second;
    auto after = std::upper_bound(candidates.begin(), candidates.end(), previous);
    if (after == candidates.end()) continue;
    if (std::next(after) != candidates.end()) ++match.ambiguous;
    previous = *after;
    match.raw_index[k] = previous;
    ++match.matched;
    const double offset = raw[previous].stamp - keyframes[k].stamp;
    offsets.push_back(offset);
    if (std::abs(offset) <= 1e-3) ++match.stamps_equal_within_1ms;
  }
  match.stamp_offset_median = Median(offsets);
  for (double offset : offsets) {
    match.stamp_offset_spread =
        std::max(match.stamp_offset_spread, std::abs(offset - match.stamp_offset_median));
  }
  return match;
}

std::string FormatFlaserLine(const CarmenLaser& laser, const std::string& host) {
  std::string line = absl::StrCat("FLASER ", laser.ranges.size());
  for (float r : laser.ranges) absl::StrAppend(&line, " ", ShortNumber(r));
  absl::StrAppend(
      &line,
      absl::StrFormat(" %.6f %.6f %.6f %.6f %.6f %.6f %.6f %s %.6f", laser.laser_pose.x,
                      laser.laser_pose.y, laser.laser_pose.theta, laser.odom_pose.x,
                      laser.odom_pose.y, laser.odom_pose.theta, laser.stamp, host, laser.stamp));
  return line;
}

}  // namespace waymark::adapters
