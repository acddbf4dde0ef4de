#ifndef WAYMARK_CLIENT_DATASETS_CARMEN_KEYFRAMES_H_
#define WAYMARK_CLIENT_DATASETS_CARMEN_KEYFRAMES_H_

// The keyframes of a GMapping-corrected CARMEN log (Stachniss' `*-corrected.log.gz` in
// ../shared/data/laser): its laser lines in file order, whose `x y theta` hold the corrected pose.
// Used as ground truth by the laser reference benchmark (bench/laser/laser_reference.cc).
//
// Their stamps are often unusable (../shared/data/laser/SOURCES.md): freiburg-campus and orebro
// have only zeros, belgioioso and csail print Unix stamps with 6 significant digits (one value for
// hundreds of keyframes), infinite-corridor has 4294967295 from its fifth line on, and Intel's
// keyframes keep the raw log's out-of-order stamps (4 of 910 go backwards). ChooseKeyframeStamps is
// the one rule that turns them into strictly increasing stamps.
//
// A corrected log's keyframes are scans of the raw log of the same run, ranges unchanged (printed
// with fewer digits: "4.1" for "4.10"), so MatchKeyframesToRaw finds each keyframe's raw line by
// its ranges, not by its stamp: the raw stamps are the ones a relations file for the raw log needs.

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/carmen_log.h"

namespace waymark::adapters {

// Every laser line (FLASER, ROBOTLASER1) of a log, in file order: nothing sorted, nothing dropped,
// since a corrected log's order is its keyframes' order whatever its stamps say. Malformed lines
// are an error here (a reference must not silently lose a keyframe).
absl::StatusOr<std::vector<CarmenLaser>> ReadLaserLinesInFileOrder(const std::string& path);

// --- stamps ----------------------------------------------------------------------------------
enum class KeyframeStampSource {
  kLog,          // the log's stamps, already strictly increasing
  kRepaired,     // the log's stamps with the few non-increasing ones pushed forward
  kSynthesized,  // t_i = kSynthesizedKeyframeIntervalS * (i + 1), the log's stamps ignored
  kRaw,          // the matched raw log's stamps (see MatchKeyframesToRaw)
};
std::string KeyframeStampSourceName(KeyframeStampSource source);

// Synthesized spacing: the median keyframe spacing of the corrected logs that have real stamps is
// 1.5-5.3 s (aces 2.15, intel 3.35, acapulco 1.51, edmonton 2.09, fhw 1.6, freiburg-101 2.57,
// seattle 5.33). 2 s keeps a relation "local" (t2 - t1 <= 10 s, waymark-laser-eval) at about five
// keyframes, as on those logs, and real-time factors comparable. (The replay's --restamp uses 5 Hz,
// the raw scan rate; corrected logs keep one scan in 5-15.)
inline constexpr double kSynthesizedKeyframeIntervalS = 2.0;
// Repair: a stamp less than kRepairStepS above the previous (repaired) one becomes previous +
// kRepairStepS; 10 ms is well above the relations' 1 ms matching tolerance, so neighbours stay
// distinct.
inline constexpr double kRepairStepS = 0.01;
// More non-increasing steps than this fraction and the log's stamps are not trusted at all.
inline constexpr double kMaxRepairedFraction = 0.01;

struct KeyframeStamps {
  KeyframeStampSource source = KeyframeStampSource::kLog;
  std::vector<double> stamps;  // strictly increasing, one per keyframe
  int repaired = 0;            // stamps changed by the repair (kRepaired only)
};

// The rule: the log's stamps when they strictly increase; repaired when at most
// kMaxRepairedFraction of the steps do not increase (and every stamp is finite); synthesized
// otherwise.
KeyframeStamps ChooseKeyframeStamps(const std::vector<double>& log_stamps);

// --- matching keyframes to the raw log -------------------------------------------------------
struct RawMatch {
  std::vector<int> raw_index;  // per keyframe: index into the raw lines, -1 when not found
  int matched = 0;
  // Keyframes whose ranges occur more than once in the raw log after the previous match (the
  // earliest is taken).
  int ambiguous = 0;
  // Over the matched keyframes: raw stamp - keyframe stamp. A corrected log with logger-relative
  // stamps has a constant offset (Intel: the raw log's start); spread = max |offset - median|
  // says how far the keyframe stamps can be trusted (6 significant digits: up to half a unit of
  // the last digit).
  double stamp_offset_median = 0;
  double stamp_offset_spread = 0;
  int stamps_equal_within_1ms = 0;  // keyframe stamp == raw stamp within 1 ms
};

// For each keyframe in order, the first raw line after the previous match whose beam count and
// ranges (rounded to the centimetre, the logs' precision) are equal. Order-preserving, so a
// keyframe can never match a scan from before the previous keyframe's.
RawMatch MatchKeyframesToRaw(const std::vector<CarmenLaser>& keyframes,
                             const std::vector<CarmenLaser>& raw);

// --- writing ---------------------------------------------------------------------------------
// One FLASER line (without the newline) of `laser`: ranges with up to 4 decimals (trailing zeros
// dropped), poses with 6, stamps with microseconds; `host` as the ipc_hostname. ParseCarmenLine
// reads it back to the same values within those precisions.
std::string FormatFlaserLine(const CarmenLaser& laser, const std::string& host);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DATASETS_CARMEN_KEYFRAMES_H_
