// waymark-laser-reference: references for the laser SLAM benchmark
// (bench/laser/laser_benchmark.sh) on logs that have no published relations, built from
// GMapping-corrected logs (Stachniss' *-corrected.log.gz in ../shared/data/laser: keyframes whose
// x y theta hold the corrected pose).
//
//   waymark-laser-reference relations --corrected LOG --out FILE.relations [--raw RAW]
//     Relations (Kummerle et al.: `t1 t2 x y z roll pitch yaw`) between the corrected keyframes:
//     sequential pairs (1, 3 and 10 keyframes apart) and loop pairs (within 2 m after >= 10 m and
//     >= 20 keyframes of travel); see client/eval/relation_builder.h. Without --raw the stamps
//     are the keyframe stamp rule's (client/datasets/carmen_keyframes.h), the same as `noisy`
//     writes. With --raw each keyframe is found in the raw log of the same run by its ranges and
//     the relations carry the RAW stamps, so `waymark-laser-eval --log RAW --relations FILE`
//     scores the raw log (MIT CSAIL). Keyframes not found in the raw log are left out.
//
//   waymark-laser-reference noisy --corrected LOG --strength none|low|medium|high --seed N
//                                 --out-log OUT.log --out-relations OUT.relations [--raw RAW]
//     A plain-text CARMEN log of FLASER lines, one per keyframe: the keyframe's ranges, the laser
//     at the robot's origin (x y theta = odom fields = the regenerated odometry pose), odometry
//     regenerated from the corrected poses with seeded error (client/eval/odometry_noise.h), and
//     the relations of the corrected poses on the same stamps. Stamps: the keyframe stamp rule, or
//     the raw log's with --raw.
//
//   waymark-laser-reference check --corrected LOG --raw RAW --relations OFFICIAL.relations
//     How good a GMapping-corrected log is as a reference, where published relations exist (ACES,
//     Intel): the corrected keyframes, carried to every raw scan by the raw odometry (the
//     correction map-from-odometry interpolated between the keyframes around the scan), scored
//     against the published relations. Also the raw log's own odometry on those relations.
//
//   waymark-laser-reference restamp --raw RAW --relations OFFICIAL.relations --out FILE.relations
//     Published relations onto a log whose stamps were regenerated (MIT Killian's rawlog-derived
//     CARMEN log): the original scan clock (period, offset) fitted from the raw odometry's agreement
//     with the local relations (client/eval/scan_clock_fit.h), each relation stamp replaced by the
//     stamp of the scan the clock names. Where the log's own stamps match the relations (ACES,
//     Intel: a test of the fit) the summary also says how many stamps the fit puts on the right scan.
//
// Every subcommand prints a JSON summary on stdout; the noisy one includes the regenerated
// odometry's own relations error (all, and local: t2 - t1 <= 10 s), the figure that
// waymark-laser-eval reports as "odometry" for the written log.

#include <cmath>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/common/write_file.h"
#include "client/datasets/carmen_keyframes.h"
#include "client/datasets/carmen_log.h"
#include "client/eval/odometry_noise.h"
#include "client/eval/relation_builder.h"
#include "client/eval/relations_metric.h"
#include "client/eval/scan_clock_fit.h"

namespace waymark::bench {
namespace {

using adapters::CarmenLaser;
using adapters::KeyframeStampSource;
using cli::Pose2;
using cli::StampedPose;

constexpr double kLocalRelationS = 10.0;  // as waymark-laser-eval's "local"

void Usage() {
  std::cerr
      << "usage: waymark-laser-reference relations --corrected LOG --out FILE [--raw RAW]\n"
         "       waymark-laser-reference noisy --corrected LOG --strength none|low|medium|high\n"
         "                               --seed N --out-log OUT.log --out-relations OUT.relations\n"
         "                               [--raw RAW]\n"
         "       waymark-laser-reference check --corrected LOG --raw RAW --relations FILE\n"
         "       waymark-laser-reference restamp --raw RAW --relations FILE --out FILE\n";
}

// --flag value pairs after the subcommand.
absl::StatusOr<std::map<std::string, std::string>> ParseFlags(
    int argc, char** argv, const std::vector<std::string>& known) {
  std::map<std::string, std::string> flags;
  for (int i = 2; i < argc; ++i) {
    const std::string name = argv[i];
    bool ok = false;
    for (const std::string& k : known) ok = ok || name == "--" + k;
    if (!ok) return absl::InvalidArgumentError(absl::StrCat("unknown option ", name));
    if (i + 1 >= argc) return absl::InvalidArgumentError(absl::StrCat("missing value for ", name));
    flags[name.substr(2)] = argv[++i];
  }
  return flags;
}

// Keyframes with their truth (the corrected pose, angle normalised so that zero noise reproduces
// it exactly) and the stamps they will carry.
struct Reference {
  std::vector<CarmenLaser> keyframes;
  std::vector<StampedPose> truth;
  KeyframeStampSource stamp_source = KeyframeStampSource::kLog;
  int read = 0;        // keyframes in the corrected log
  int repaired = 0;    // stamps repaired (kRepaired)
  nlohmann::json raw;  // the --raw match, when asked
};

absl::StatusOr<std::vector<CarmenLaser>> ReadNonEmpty(const std::string& path) {
  absl::StatusOr<std::vector<CarmenLaser>> lasers = adapters::ReadLaserLinesInFileOrder(path);
  if (!lasers.ok()) return lasers.status();
  if (lasers->empty()) return absl::InvalidArgumentError(absl::StrCat(path, ": no laser lines"));
  return lasers;
}

Pose2 TruthOf(const CarmenLaser& keyframe) {
  return {keyframe.laser_pose.x, keyframe.laser_pose.y,
          cli::NormalizeAngle(keyframe.laser_pose.theta)};
}

nlohmann::json MatchJson(const adapters::RawMatch& match, const std::vector<CarmenLaser>& raw,
                         size_t keyframes) {
  return {{"raw_scans", raw.size()},
          {"keyframes", keyframes},
          {"matched_by_ranges", match.matched},
          {"ambiguous", match.ambiguous},
          {"stamps_equal_within_1ms", match.stamps_equal_within_1ms},
          {"stamp_offset_median_s", match.stamp_offset_median},
          {"stamp_offset_spread_s", match.stamp_offset_spread}};
}

absl::StatusOr<Reference> LoadReference(const std::string& corrected, const std::string& raw_path) {
  absl::StatusOr<std::vector<CarmenLaser>> keyframes = ReadNonEmpty(corrected);
  if (!keyframes.ok()) return keyframes.status();
  Reference ref;
  ref.read = static_cast<int>(keyframes->size());
  if (raw_path.empty()) {
    std::vector<double> log_stamps;
    for (const CarmenLaser& k : *keyframes) log_stamps.push_back(k.stamp);
    adapters::KeyframeStamps stamps = adapters::ChooseKeyframeStamps(log_stamps);
    ref.stamp_source = stamps.source;
    ref.repaired = stamps.repaired;
    for (size_t i = 0; i < keyframes->size(); ++i) {
      CarmenLaser& k = (*keyframes)[i];
      k.stamp = stamps.stamps[i];
      ref.truth.push_back({k.stamp, TruthOf(k)});
    }
    ref.keyframes = *std::move(keyframes);
    return ref;
  }
  absl::StatusOr<std::vector<CarmenLaser>> raw = ReadNonEmpty(raw_path);
  if (!raw.ok()) return raw.status();
  const adapters::RawMatch match = adapters::MatchKeyframesToRaw(*keyframes, *raw);
  if (match.matched == 0) {
    return absl::NotFoundError(absl::StrCat("no keyframe of ", corrected, " found in ", raw_path));
  }
  ref.stamp_source = KeyframeStampSource::kRaw;
  ref.raw = MatchJson(match, *raw, keyframes->size());
  double previous = -INFINITY;
  int not_increasing = 0;
  for (size_t i = 0; i < keyframes->size(); ++i) {
    if (match.raw_index[i] < 0) continue;
    CarmenLaser k = (*keyframes)[i];
    k.stamp = (*raw)[match.raw_index[i]].stamp;
    if (!(k.stamp > previous)) ++not_increasing;
    previous = k.stamp;
    ref.truth.push_back({k.stamp, TruthOf(k)});
    ref.keyframes.push_back(std::move(k));
  }
  // Intel's raw lines are out of order; a keyframe's raw stamp can be below the previous one's.
  // The relations only name scans, so that is harmless, but worth knowing.
  ref.raw["raw_stamps_not_increasing"] = not_increasing;
  return ref;
}

nlohmann::json ReferenceJson(const Reference& ref) {
  nlohmann::json j = {{"keyframes_read", ref.read},
                      {"keyframes_used", ref.keyframes.size()},
                      {"stamp_source", adapters::KeyframeStampSourceName(ref.stamp_source)},
                      {"stamps_repaired", ref.repaired}};
  if (!ref.raw.is_null()) j["raw_match"] = ref.raw;
  return j;
}

nlohmann::json MetricJson(const cli::RelationsResult& r) {
  return {{"relations", r.relations},
          {"relations_used", r.relations_used},
          {"trans_abs_mean_m", r.trans_abs.mean},
          {"trans_abs_std_m", r.trans_abs.std},
          {"rot_abs_mean_deg", r.rot_abs_deg.mean},
          {"rot_abs_std_deg", r.rot_abs_deg.std},
          {"trans_abs_max_m", r.trans_abs_max}};
}

// `trajectory` scored on all relations and on the local ones (t2 - t1 <= 10 s).
nlohmann::json ScoreJson(const std::vector<StampedPose>& trajectory,
                         const std::vector<cli::Relation>& relations) {
  std::vector<cli::Relation> local;
  for (const cli::Relation& r : relations) {
    if (std::abs(r.t2 - r.t1) <= kLocalRelationS) local.push_back(r);
  }
  return {{"all", MetricJson(cli::EvaluateRelations(trajectory, relations))},
          {"local", MetricJson(cli::EvaluateRelations(trajectory, local))}};
}

nlohmann::json BuiltJson(const cli::BuiltRelations& built) {
  return {{"relations", built.relations.size()},
          {"sequential", built.sequential},
          {"loops", built.loops},
          {"loop_candidates", built.loop_candidates}};
}

absl::Status WriteText(const std::string& path, const std::string& text) {
  return cli::WriteFileBytes(path, text);
}

std::vector<std::string> RelationsHeader(const std::string& what, const Reference& ref) {
  return {absl::StrCat("waymark-laser-reference ", what),
          absl::StrCat("stamps: ", adapters::KeyframeStampSourceName(ref.stamp_source),
                       " (client/datasets/carmen_keyframes.h); truth: GMapping-corrected poses"),
          "t1 t2 x y z roll pitch yaw: pose of the scan at t2 in the frame of the scan at t1"};
}

int RunRelations(const std::map<std::string, std::string>& flags) {
  const std::string raw = flags.count("raw") ? flags.at("raw") : "";
  absl::StatusOr<Reference> ref = LoadReference(flags.at("corrected"), raw);
  if (!ref.ok()) {
    std::cerr << ref.status() << "\n";
    return 1;
  }
  const cli::BuiltRelations built = cli::BuildRelations(ref->truth);
  const std::string what = absl::StrCat("relations --corrected ", flags.at("corrected"),
                                        raw.empty() ? "" : absl::StrCat(" --raw ", raw));
  if (absl::Status s = WriteText(
          flags.at("out"), cli::FormatRelations(built.relations, RelationsHeader(what, *ref)));
      !s.ok()) {
    std::cerr << s << "\n";
    return 1;
  }
  nlohmann::json j = ReferenceJson(*ref);
  j["corrected"] = flags.at("corrected");
  if (!raw.empty()) j["raw"] = raw;
  j["out"] = flags.at("out");
  j["built"] = BuiltJson(built);
  std::cout << j.dump(2) << "\n";
  return 0;
}

int RunNoisy(const std::map<std::string, std::string>& flags) {
  absl::StatusOr<cli::NoiseStrength> strength = cli::ParseNoiseStrength(flags.at("strength"));
  if (!strength.ok()) {
    std::cerr << strength.status() << "\n";
    return 2;
  }
  uint64_t seed = 0;
  try {
    seed = std::stoull(flags.at("seed"));
  } catch (...) {
    std::cerr << "bad --seed " << flags.at("seed") << "\n";
    return 2;
  }
  const std::string raw = flags.count("raw") ? flags.at("raw") : "";
  absl::StatusOr<Reference> ref = LoadReference(flags.at("corrected"), raw);
  if (!ref.ok()) {
    std::cerr << ref.status() << "\n";
    return 1;
  }
  for (const CarmenLaser& k : ref->keyframes) {
    // The log written is FLASER, whose beam geometry is CARMEN's convention by beam count.
    if (k.kind != CarmenLaser::Kind::kFlaser) {
      std::cerr << flags.at("corrected") << ": noisy logs are made from FLASER keyframes only\n";
      return 1;
    }
  }
  const cli::OdometryNoise noise = cli::NoiseFor(*strength);
  std::vector<Pose2> truth;
  for (const StampedPose& p : ref->truth) truth.push_back(p.pose);
  const cli::NoisyOdometry odometry = cli::GenerateNoisyOdometry(truth, noise, seed);

  std::string log = absl::StrCat(
      "# waymark-laser-reference noisy --corrected ", flags.at("corrected"),
      raw.empty() ? "" : absl::StrCat(" --raw ", raw), " --strength ",
      cli::NoiseStrengthName(*strength), " --seed ", seed, "\n# noise: ", cli::DescribeNoise(noise),
      absl::StrFormat("; signs: scale %+g turn %+g drift %+g\n", odometry.scale_sign,
                      odometry.turn_sign, odometry.drift_sign),
      "# stamps: ", adapters::KeyframeStampSourceName(ref->stamp_source),
      "; laser at the robot's origin: x y theta = odom = the regenerated odometry\n");
  std::vector<StampedPose> odometry_stamped;
  for (size_t i = 0; i < ref->keyframes.size(); ++i) {
    CarmenLaser line = ref->keyframes[i];
    const Pose2& p = odometry.poses[i];
    line.laser_pose = {p.x, p.y, p.theta};
    line.odom_pose = line.laser_pose;
    absl::StrAppend(&log, adapters::FormatFlaserLine(line, "noisy"), "\n");
    odometry_stamped.push_back({line.stamp, p});
  }
  const cli::BuiltRelations built = cli::BuildRelations(ref->truth);
  const std::string what = absl::StrCat("noisy --corrected ", flags.at("corrected"));
  if (absl::Status s = WriteText(flags.at("out-log"), log); !s.ok()) {
    std::cerr << s << "\n";
    return 1;
  }
  if (absl::Status s =
          WriteText(flags.at("out-relations"),
                    cli::FormatRelations(built.relations, RelationsHeader(what, *ref)));
      !s.ok()) {
    std::cerr << s << "\n";
    return 1;
  }
  double path_m = 0;
  for (size_t i = 1; i < truth.size(); ++i) {
    path_m += std::hypot(truth[i].x - truth[i - 1].x, truth[i].y - truth[i - 1].y);
  }
  nlohmann::json j = ReferenceJson(*ref);
  j["corrected"] = flags.at("corrected");
  j["strength"] = cli::NoiseStrengthName(*strength);
  j["seed"] = seed;
  j["noise"] = cli::DescribeNoise(noise);
  j["beams"] = ref->keyframes.front().ranges.size();
  j["path_m"] = path_m;
  j["duration_s"] = ref->truth.back().stamp - ref->truth.front().stamp;
  j["out_log"] = flags.at("out-log");
  j["out_relations"] = flags.at("out-relations");
  j["built"] = BuiltJson(built);
  j["odometry_error"] = ScoreJson(odometry_stamped, built.relations);
  std::cout << j.dump(2) << "\n";
  return 0;
}

// Between keyframes a < b (raw indices), the map-from-odometry correction K = C (+) inv(O) is
// interpolated linearly in the raw line index (x, y, and the angle along its shorter way).
Pose2 Interpolate(const Pose2& a, const Pose2& b, double f) {
  return {a.x + f * (b.x - a.x), a.y + f * (b.y - a.y),
          cli::NormalizeAngle(a.theta + f * cli::NormalizeAngle(b.theta - a.theta))};
}

int RunCheck(const std::map<std::string, std::string>& flags) {
  absl::StatusOr<std::vector<CarmenLaser>> keyframes = ReadNonEmpty(flags.at("corrected"));
  absl::StatusOr<std::vector<CarmenLaser>> raw = ReadNonEmpty(flags.at("raw"));
  absl::StatusOr<std::vector<cli::Relation>> official =
      cli::ReadRelationsFile(flags.at("relations"));
  for (const absl::Status& s : {keyframes.status(), raw.status(), official.status()}) {
    if (!s.ok()) {
      std::cerr << s << "\n";
      return 1;
    }
  }
  const adapters::RawMatch match = adapters::MatchKeyframesToRaw(*keyframes, *raw);
  std::vector<std::pair<int, Pose2>> corrections;  // (raw index, K), raw index increasing
  std::vector<StampedPose> at_keyframes;
  for (size_t k = 0; k < keyframes->size(); ++k) {
    const int r = match.raw_index[k];
    if (r < 0) continue;
    const CarmenLaser& scan = (*raw)[r];
    const Pose2 odom{scan.laser_pose.x, scan.laser_pose.y, scan.laser_pose.theta};
    const Pose2 truth = TruthOf((*keyframes)[k]);
    corrections.emplace_back(r, cli::Compose(truth, cli::Inverse(odom)));
    at_keyframes.push_back({scan.stamp, truth});
  }
  if (corrections.empty()) {
    std::cerr << "no keyframe found in the raw log\n";
    return 1;
  }
  std::vector<StampedPose> dense, raw_odometry;
  size_t next = 0;  // first correction at or after the scan
  for (size_t i = 0; i < raw->size(); ++i) {
    while (next < corrections.size() && corrections[next].first < static_cast<int>(i)) ++next;
    Pose2 k;
    if (next == 0) {
      k = corrections.front().second;
    } else if (next == corrections.size()) {
      k = corrections.back().second;
    } else {
      const auto& [ia, ka] = corrections[next - 1];
      const auto& [ib, kb] = corrections[next];
      k = Interpolate(ka, kb, static_cast<double>(i - ia) / (ib - ia));
    }
    const CarmenLaser& scan = (*raw)[i];
    const Pose2 odom{scan.laser_pose.x, scan.laser_pose.y, scan.laser_pose.theta};
    dense.push_back({scan.stamp, cli::Compose(k, odom)});
    raw_odometry.push_back({scan.stamp, odom});
  }
  nlohmann::json j = {{"corrected", flags.at("corrected")},
                      {"raw", flags.at("raw")},
                      {"relations", flags.at("relations")},
                      {"raw_match", MatchJson(match, *raw, keyframes->size())},
                      {"keyframes_with_odometry_between", ScoreJson(dense, *official)},
                      {"keyframes_only", ScoreJson(at_keyframes, *official)},
                      // The raw log's own odometry on the same relations: the yardstick of the
                      // noisy-odometry levels (what waymark-laser-eval reports as "odometry").
                      {"raw_odometry", ScoreJson(raw_odometry, *official)}};
  std::cout << j.dump(2) << "\n";
  return 0;
}

// Where the log's stamps are the relations' own (a test of the fit): how far the fitted clock puts
// each relation stamp from the scan that carries it.
nlohmann::json AgainstLogStamps(const cli::ScanClockFit& fit, const std::vector<double>& stamps,
                                const std::vector<cli::Relation>& relations) {
  std::map<double, int> index_of;  // stamp -> scan index (the first on repeats)
  for (size_t i = 0; i < stamps.size(); ++i) index_of.emplace(stamps[i], static_cast<int>(i));
  int found = 0, exact = 0, within_one = 0, worst = 0;
  for (const cli::Relation& r : relations) {
    for (double t : {r.t1, r.t2}) {
      auto it = index_of.lower_bound(t - 1e-3);
      if (it == index_of.end() || it->first > t + 1e-3) continue;
      ++found;
      const int off = std::abs(fit.IndexOf(t, static_cast<int>(stamps.size())) - it->second);
      exact += off == 0;
      within_one += off <= 1;
      worst = std::max(worst, off);
    }
  }
  if (found < static_cast<int>(relations.size())) return nullptr;  // not the relations' log
  return {{"stamps", found}, {"on_the_right_scan", exact}, {"within_one_scan", within_one},
          {"worst_scans_off", worst}};
}

int RunRestamp(const std::map<std::string, std::string>& flags) {
  absl::StatusOr<std::vector<CarmenLaser>> raw = ReadNonEmpty(flags.at("raw"));
  absl::StatusOr<std::vector<cli::Relation>> official =
      cli::ReadRelationsFile(flags.at("relations"));
  for (const absl::Status& s : {raw.status(), official.status()}) {
    if (!s.ok()) {
      std::cerr << s << "\n";
      return 1;
    }
  }
  std::vector<Pose2> odometry;
  std::vector<double> stamps;
  for (const CarmenLaser& scan : *raw) {
    odometry.push_back({scan.odom_pose.x, scan.odom_pose.y, scan.odom_pose.theta});
    stamps.push_back(scan.stamp);
  }
  absl::StatusOr<cli::ScanClockFit> fit = cli::FitScanClock(odometry, *official);
  if (!fit.ok()) {
    std::cerr << fit.status() << "\n";
    return 1;
  }
  int dropped = 0;
  const std::vector<cli::Relation> moved = cli::RestampRelations(*official, *fit, stamps, &dropped);
  const std::string header = absl::StrFormat(
      "%s restamped by waymark-laser-reference: scan = (t - %.3f) / %.6f + %.2f",
      flags.at("relations"), fit->t0, fit->period, fit->offset);
  absl::Status written = cli::WriteFileBytes(flags.at("out"),
                                                     cli::FormatRelations(moved, {header}));
  if (!written.ok()) {
    std::cerr << written << "\n";
    return 1;
  }
  std::vector<StampedPose> raw_odometry;
  for (size_t i = 0; i < odometry.size(); ++i) raw_odometry.push_back({stamps[i], odometry[i]});
  nlohmann::json j = {{"raw", flags.at("raw")},
                      {"relations", flags.at("relations")},
                      {"out", flags.at("out")},
                      {"scans", odometry.size()},
                      {"fit",
                       {{"t0", fit->t0},
                        {"period_s", fit->period},
                        {"offset_scans", fit->offset},
                        {"local_relations", fit->local_relations},
                        {"cost", fit->cost},
                        {"cost_one_scan_earlier", fit->cost_minus_one},
                        {"cost_one_scan_later", fit->cost_plus_one}}},
                      {"relations_written", moved.size()},
                      {"relations_dropped", dropped},
                      {"raw_odometry", ScoreJson(raw_odometry, moved)}};
  nlohmann::json check = AgainstLogStamps(*fit, stamps, *official);
  if (!check.is_null()) j["against_log_stamps"] = check;
  std::cout << j.dump(2) << "\n";
  return 0;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  using namespace waymark::bench;
  if (argc < 2) {
    Usage();
    return 2;
  }
  const std::string command = argv[1];
  // Each command's options, the first `required` of them required.
  std::vector<std::string> known;
  size_t required = 0;
  int (*run)(const std::map<std::string, std::string>&) = nullptr;
  if (command == "relations") {
    known = {"corrected", "out", "raw"};
    required = 2;
    run = RunRelations;
  } else if (command == "noisy") {
    known = {"corrected", "strength", "seed", "out-log", "out-relations", "raw"};
    required = 5;
    run = RunNoisy;
  } else if (command == "check") {
    known = {"corrected", "raw", "relations"};
    required = 3;
    run = RunCheck;
  } else if (command == "restamp") {
    known = {"raw", "relations", "out"};
    required = 3;
    run = RunRestamp;
  } else {
    Usage();
    return 2;
  }
  absl::StatusOr<std::map<std::string, std::string>> flags = ParseFlags(argc, argv, known);
  if (!flags.ok()) {
    std::cerr << flags.status().message() << "\n";
    Usage();
    return 2;
  }
  for (size_t i = 0; i < required; ++i) {
    if (!flags->count(known[i])) {
      std::cerr << command << " needs --" << known[i] << "\n";
      return 2;
    }
  }
  return run(*flags);
}
