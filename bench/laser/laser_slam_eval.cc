// waymark-laser-eval: the laser SLAM engine alone (in-process, no server) on a CARMEN log.
//
//   waymark-laser-eval --log LOG [--relations FILE] [--max-scans N] [--start-fraction F]
//                      [--odometry-lag auto|N] [--out DIR] [--json]
//                      [--max-active-segments N] [--active-radius M] [--freeze-after-scans N]
//                      [--min-travel M --min-turn R] [--match-chi2 X]
//
// All laser lines (FLASER / ROBOTLASER1) are read first, stable-sorted by stamp (the Intel log has
// lines out of order) and lines with a stamp equal to the previous one are dropped and counted.
// Then, as `waymark slam replay` sends them (client/sessions/slam_replay.h): per line, AddOdometry
// with the odometry pose embedded in the line at the line's stamp, then AddScan with the line's
// own beam geometry; the laser's mounting comes from the first line (cli::LaserMount). Only the
// two engine calls are timed (steady clock), never the reading.
//
// Reported: scans, log duration, engine seconds, real-time factor (duration / engine seconds),
// per-scan time p50/p90/p99/max, the same p50/p99 binned by the number of segments in the filter
// after the scan (active_segments; bins of 50: 0-49, 50-99, ...), final segments (total, active),
// peak RSS (getrusage; includes the log held in memory, see rss_after_load_mb). With --relations:
// the relations metric (Kummerle et al.) of the SLAM trajectory and of the raw odometry at the same
// stamps, over all relations and over the "local" ones (t2 - t1 <= 10 s), which separates local
// accuracy from long-range drift (the engine closes no loops).
//
// Update cost against the size of the state ("EKF update p99 at 300 segments"): building a state of
// N segments synthetically is not possible through the engine's public API, so it is measured on
// real data instead: run the ACES log with a larger active window,
//   waymark-laser-eval --log aces.clf.bz2 --max-active-segments 400 --active-radius 1000
//                      --freeze-after-scans 1000000
// and read the per-bin p50/p99 (bins of active segments); bench/run.sh does this. The figure for
// "300 segments" is the p99 of the 300-349 bin. The radius and freeze settings are needed: with the
// defaults (12 m, 20 scans) segments freeze long before the cap and ACES never has more than about
// 140 active segments, whatever --max-active-segments says.
//
// --resume-every N replaces the engine every N scans by LaserSlam::FromCheckpoint of its own
// state and local trajectory (what a server restart does): final_state_digest (of the final
// checkpoint's bytes) should equal the run's without it, which tells whether a checkpoint loses
// anything.
//
// With loop closure on, the map's self-check (laser_map_check.h) runs on the final graph:
// "self_check" in the JSON, its verdict on the last line. --save-nodes FILE keeps the graph's
// nodes, for waymark-map-check to check again with other settings; --save-closures FILE the
// loop constraints (one line each: from and to node stamps, the relative pose, its sigmas,
// enabled, score) to check them against a reference. --check-after-optimisations
// incremental|full also runs it after every optimisation (untimed as the engine's) and reports
// what that costs ("self_check.after_optimisations"). --picture FILE.png writes a small picture
// of the checked map (the occupancy grid, its longer side --picture-size pixels, default 360;
// contradicting cells in red; an 8-bit palette PNG of tens of KB) for a page of many maps
// (bench/laser/laser_benchmark.sh --pictures).
//
// --out DIR writes trajectory.txt and odometry.txt (TUM), map.svg / map.png (segments and the
// trajectory; contradicting cells in red), occupancy.png (the occupancy grid at the optimised
// poses, contradicting cells in red, areas that contradict themselves outlined in orange) and
// summary.json; --json prints the same JSON object on stdout.

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <stdexcept>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/common/bench_timing.h"
#include "bench/laser/laser_map_check.h"
#include "client/datasets/carmen_log.h"
#include "client/datasets/odometry_lag.h"
#include "client/render/map_render.h"
#include "client/eval/relations_metric.h"
#include "client/sessions/slam_replay.h"
#include "client/datasets/tum_trajectory.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/options.h"

namespace waymark::bench {
namespace {

namespace ls = waymark::laser_slam;
using adapters::CarmenLaser;
using adapters::CarmenLogReader;
using adapters::CarmenRecord;
using Clock = std::chrono::steady_clock;

constexpr double kLocalRelationS = 10.0;
constexpr int kBinWidth = 50;

struct Args {
  std::string log;
  std::string relations;
  std::string out;
  std::string save_nodes;  // --save-nodes FILE: the final graph's nodes (laser_map_check.h)
  std::string save_closures;  // --save-closures FILE: the final graph's loop constraints
  std::string picture;     // --picture FILE.png: a small picture of the checked map
  int picture_size = 360;  // --picture-size N: its longer side (pixels)
  std::string check_after_optimisations;  // "incremental" or "full": OptimisationChecks
  int max_scans = 0;
  double start_fraction = 0.0;  // --start-fraction F: the log from F of its laser lines on
  // --odometry-lag auto|N: scan i takes the odometry the log gives scan i + N (N may be a
  // fraction: interpolated); auto (the default): client/datasets/odometry_lag.h's estimate.
  bool odometry_lag_auto = true;
  double odometry_lag = 0;
  int resume_every = 0;  // --resume-every N: replace the engine by its checkpoint every N scans
  bool json = false;
  ls::SlamOptions options;
  // --localize: after mapping, localize the same log on the map from scan localize_from, with an
  // unknown start (or the SLAM pose there with --localize-known-start).
  bool localize = false;
  int localize_from = 0;
  bool localize_known_start = false;
  bool localize_on_grid = false;  // the map as an exported grid's occupied cells (import-map)
  int localize_track_nodes = 0;   // LocalizationOptions::track_query_nodes; 0 = its default
};

void Usage() {
  std::cerr
      << "usage: waymark-laser-eval --log LOG [--relations FILE] [--max-scans N] [--out DIR]\n"
         "                          [--start-fraction F] [--odometry-lag auto|N]\n"
         "                          [--resume-every N]\n"
         "                          [--json] [--max-active-segments N] [--active-radius M]\n"
         "                          [--freeze-after-scans N] [--min-travel M --min-turn R]\n"
         "                          [--match-chi2 X] [--mapping on|off]\n"
         "                          [--mapping-opt NAME=VALUE ...] [--save-nodes FILE] [--save-closures FILE]\n"
         "                          [--picture FILE.png [--picture-size N]]\n"
         "                          [--check-after-optimisations incremental|full]\n"
         "                          [--localize [--localize-from SCAN] [--localize-known-start]\n"
         "                           [--localize-on-grid] [--localize-track-nodes N]]\n";
}

std::string StateDigest(const std::string& bytes) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ULL;
  return absl::StrFormat("%016x", h);
}

// --mapping-opt NAME=VALUE: one MappingOptions field by name (for tuning runs).
bool SetMappingOption(const std::string& assignment, ls::MappingOptions* m) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos) return false;
  const std::string name = assignment.substr(0, eq);
  const double value = std::stod(assignment.substr(eq + 1));
  const std::map<std::string, double*> doubles = {
      {"node_travel", &m->node_travel}, {"node_turn", &m->node_turn},
      {"point_range", &m->point_range}, {"point_cell", &m->point_cell},
      {"grid_resolution", &m->grid_resolution}, {"grid_sigma", &m->grid_sigma},
      {"min_loop_travel", &m->min_loop_travel}, {"candidate_distance", &m->candidate_distance},
      {"loop_window_sigmas", &m->loop_window_sigmas},
      {"loop_window_min_xy", &m->loop_window_min_xy},
      {"loop_window_min_theta", &m->loop_window_min_theta}, {"max_window_xy", &m->max_window_xy},
      {"rival_ratio", &m->rival_ratio}, {"rival_exclusion", &m->rival_exclusion},
      {"rival_far", &m->rival_far},
      {"min_score", &m->min_score},
      {"global_min_overlap", &m->global_min_overlap},
      {"chain_sigma_xy", &m->chain_sigma_xy}, {"chain_sigma_xy_per_m", &m->chain_sigma_xy_per_m},
      {"chain_sigma_theta", &m->chain_sigma_theta},
      {"chain_sigma_theta_per_m", &m->chain_sigma_theta_per_m},
      {"chain_sigma_theta_per_rad", &m->chain_sigma_theta_per_rad},
      {"loop_sigma_xy", &m->loop_sigma_xy}, {"loop_sigma_theta", &m->loop_sigma_theta},
      {"huber_scale", &m->huber_scale}, {"outlier_residual", &m->outlier_residual},
      {"local_window_sigmas", &m->local_window_sigmas},
      {"local_window_min_xy", &m->local_window_min_xy},
      {"local_window_min_theta", &m->local_window_min_theta},
      {"local_min_score", &m->local_min_score}, {"local_sigma_xy", &m->local_sigma_xy},
      {"local_sigma_theta", &m->local_sigma_theta},
      {"local_points_per_observation", &m->local_points_per_observation},
      {"local_wide_window_xy", &m->local_wide_window_xy},
      {"local_wide_window_theta", &m->local_wide_window_theta},
      {"prune_max_new_fraction", &m->prune_max_new_fraction}, {"prune_cell", &m->prune_cell}};
  if (name == "local_prior") {  // 0: EKF within odometry, 1: odometry, 2: EKF
    if (value != 0.0 && value != 1.0 && value != 2.0) return false;
    m->local_prior = static_cast<ls::MappingOptions::LocalPrior>(static_cast<int>(value));
    return true;
  }
  const std::map<std::string, bool*> bools = {
      {"local_odometry_hypothesis", &m->local_odometry_hypothesis},
      {"local_learned_prior", &m->local_learned_prior},
      {"local_widen_at_heading_edge", &m->local_widen_at_heading_edge},
      {"local_unmatched_odometry", &m->local_unmatched_odometry},
      {"local_ignore_edge_translation", &m->local_ignore_edge_translation},
      {"global_within_window", &m->global_within_window},
      {"window_through_ties", &m->window_through_ties},
      {"interpolate_corrections", &m->interpolate_corrections},
      {"windowed_where_seen", &m->windowed_where_seen},
      {"confirm_global_closures", &m->confirm_global_closures},
      {"search_where_closures_put", &m->search_where_closures_put},
      {"windows_wait_for_closures_that_move", &m->windows_wait_for_closures_that_move},
      {"loosen_ridges", &m->loosen_ridges},
      {"prune_redundant_submaps", &m->prune_redundant_submaps},
      {"prune_keep_closures", &m->prune_keep_closures},
      {"local_matching", &m->local_matching}};
  if (auto it = bools.find(name); it != bools.end()) {
    *it->second = value != 0.0;
    return true;
  }
  const std::map<std::string, int*> ints = {
      {"threads", &m->threads}, {"submap_nodes", &m->submap_nodes},
      {"search_every_nodes", &m->search_every_nodes}, {"query_nodes", &m->query_nodes},
      {"max_candidates", &m->max_candidates}, {"search_depth", &m->search_depth},
      {"optimize_every_closures", &m->optimize_every_closures},
      {"max_iterations", &m->max_iterations}, {"local_map_nodes", &m->local_map_nodes},
      {"global_search_every_nodes", &m->global_search_every_nodes},
      {"coarse_search_factor", &m->coarse_search_factor},
      {"confirm_within_nodes", &m->confirm_within_nodes},
      {"prune_after_submaps", &m->prune_after_submaps}, {"prune_min_ties", &m->prune_min_ties}};
  if (auto it = doubles.find(name); it != doubles.end()) {
    *it->second = value;
    return true;
  }
  if (auto it = ints.find(name); it != ints.end()) {
    *it->second = static_cast<int>(value);
    return true;
  }
  return false;
}

bool ParseArgs(int argc, char** argv, Args* args) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--json") {
      args->json = true;
      continue;
    }
    if (a == "-h" || a == "--help") return false;
    if (a == "--localize") {
      args->localize = true;
      continue;
    }
    if (a == "--localize-on-grid") {
      args->localize_on_grid = true;
      continue;
    }
    if (a == "--localize-known-start") {
      args->localize_known_start = true;
      continue;
    }
    if (i + 1 >= argc) {
      std::cerr << "missing value for " << a << "\n";
      return false;
    }
    const std::string v = argv[++i];
    try {
      if (a == "--log") {
        args->log = v;
      } else if (a == "--relations") {
        args->relations = v;
      } else if (a == "--out") {
        args->out = v;
      } else if (a == "--save-nodes") {
        args->save_nodes = v;
      } else if (a == "--save-closures") {
        args->save_closures = v;
      } else if (a == "--picture") {
        args->picture = v;
      } else if (a == "--picture-size") {
        args->picture_size = std::stoi(v);
        if (args->picture_size < 16 || args->picture_size > 4000) throw std::invalid_argument(v);
      } else if (a == "--check-after-optimisations") {
        if (v != "incremental" && v != "full") throw std::invalid_argument(v);
        args->check_after_optimisations = v;
      } else if (a == "--max-scans") {
        args->max_scans = std::stoi(v);
      } else if (a == "--start-fraction") {
        args->start_fraction = std::stod(v);
        if (!(args->start_fraction >= 0.0 && args->start_fraction < 1.0)) {
          throw std::invalid_argument(v);
        }
      } else if (a == "--odometry-lag") {
        args->odometry_lag_auto = v == "auto";
        if (!args->odometry_lag_auto) {
          args->odometry_lag = std::stod(v);
          if (!(std::abs(args->odometry_lag) <= 1000)) throw std::invalid_argument(v);
        }
      } else if (a == "--resume-every") {
        args->resume_every = std::stoi(v);
      } else if (a == "--max-active-segments") {
        args->options.ekf.max_active_segments = std::stoi(v);
      } else if (a == "--active-radius") {
        args->options.ekf.active_radius = std::stod(v);
      } else if (a == "--freeze-after-scans") {
        args->options.ekf.freeze_after_scans = std::stoi(v);
      } else if (a == "--min-travel") {
        args->options.ekf.min_travel = std::stod(v);
      } else if (a == "--min-turn") {
        args->options.ekf.min_turn = std::stod(v);
      } else if (a == "--match-chi2") {
        args->options.ekf.match_chi2 = std::stod(v);
      } else if (a == "--localize-track-nodes") {
        args->localize_track_nodes = std::stoi(v);
      } else if (a == "--localize-from") {
        args->localize_from = std::stoi(v);
      } else if (a == "--mapping") {
        if (v != "on" && v != "off") throw std::invalid_argument(v);
        args->options.mapping.enabled = v == "on";
      } else if (a == "--mapping-opt") {
        if (!SetMappingOption(v, &args->options.mapping)) throw std::invalid_argument(v);
      } else {
        std::cerr << "unknown option " << a << "\n";
        return false;
      }
    } catch (...) {
      std::cerr << "bad value for " << a << ": " << v << "\n";
      return false;
    }
  }
  if (args->log.empty()) {
    std::cerr << "--log is required\n";
    return false;
  }
  return true;
}

double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // Linux: KiB
}

struct LogLasers {
  std::vector<CarmenLaser> lasers;  // stamp order, no repeated stamp
  int64_t duplicate_stamps = 0;
  int64_t out_of_order = 0;  // lines whose stamp is below one read earlier
  int64_t malformed = 0;
  std::vector<std::string> first_errors;
};

absl::StatusOr<LogLasers> ReadLasers(const std::string& path) {
  auto reader = CarmenLogReader::Open(path);
  if (!reader.ok()) return reader.status();
  LogLasers out;
  CarmenRecord record;
  double max_read = -INFINITY;
  while (true) {
    auto more = (*reader)->Next(&record);
    if (!more.ok()) return more.status();
    if (!*more) break;
    if (record.type != CarmenRecord::Type::kLaser) continue;
    if (record.laser.stamp < max_read) ++out.out_of_order;
    max_read = std::max(max_read, record.laser.stamp);
    out.lasers.push_back(std::move(record.laser));
  }
  out.malformed = (*reader)->malformed_lines();
  out.first_errors = (*reader)->first_errors();
  std::stable_sort(out.lasers.begin(), out.lasers.end(),
                   [](const CarmenLaser& a, const CarmenLaser& b) { return a.stamp < b.stamp; });
  std::vector<CarmenLaser> unique;
  unique.reserve(out.lasers.size());
  for (CarmenLaser& laser : out.lasers) {
    if (!unique.empty() && !(laser.stamp > unique.back().stamp)) {
      ++out.duplicate_stamps;
      continue;
    }
    unique.push_back(std::move(laser));
  }
  out.lasers = std::move(unique);
  return out;
}

nlohmann::json MetricJson(const cli::RelationsResult& r) {
  return {{"relations", r.relations},         {"relations_used", r.relations_used},
          {"trans_abs_mean_m", r.trans_abs.mean}, {"trans_abs_std_m", r.trans_abs.std},
          {"trans_sq_mean_m2", r.trans_sq.mean},  {"rot_abs_mean_deg", r.rot_abs_deg.mean},
          {"rot_abs_std_deg", r.rot_abs_deg.std}, {"rot_sq_mean_deg2", r.rot_sq_deg2.mean},
          {"trans_abs_max_m", r.trans_abs_max},   {"rot_abs_max_deg", r.rot_abs_max_deg}};
}

std::string MetricLine(const cli::RelationsResult& r) {
  return absl::StrFormat("%5d/%-5d used  trans %.3f +- %.3f m (max %.2f)  rot %.2f +- %.2f deg",
                         r.relations_used, r.relations, r.trans_abs.mean, r.trans_abs.std,
                         r.trans_abs_max, r.rot_abs_deg.mean, r.rot_abs_deg.std);
}

cli::SceneSegment SceneOf(const ls::MapSegment& s) {
  const double c = std::cos(s.frame.theta), sn = std::sin(s.frame.theta);
  cli::SceneSegment out;
  out.a = {s.frame.x + c * s.left, s.frame.y + sn * s.left};
  out.b = {s.frame.x + c * s.right, s.frame.y + sn * s.right};
  out.a_real = s.left_type == ls::EndpointType::kReal;
  out.b_real = s.right_type == ls::EndpointType::kReal;
  return out;
}

// The odometry pose embedded in a laser line, at its stamp (as slam replay sends it).
ls::OdometryReading ToOdometry(const CarmenLaser& laser) {
  ls::OdometryReading reading;
  reading.stamp = laser.stamp;
  reading.pose = {laser.odom_pose.x, laser.odom_pose.y, laser.odom_pose.theta};
  return reading;
}


// The log again, as a localization session on the map just built: pose error against the SLAM
// trajectory (same stamps, same map frame), time to the first fix, wrong fixes, cost per scan.
absl::StatusOr<nlohmann::json> RunLocalization(const Args& args, const ls::SlamOptions& options,
                                               const std::vector<CarmenLaser>& lasers,
                                               const ls::LaserSlam& mapped) {
  absl::StatusOr<ls::PointCloud> points = mapped.MapPoints();
  if (args.localize_on_grid) {
    absl::StatusOr<ls::OccupancyGrid> grid = mapped.RenderGrid(0.05);
    if (!grid.ok()) return grid.status();
    points = ls::OccupiedPoints(*grid);
  }
  if (!points.ok()) return points.status();
  const std::vector<ls::PoseEstimate> reference = mapped.Trajectory();
  const size_t from = std::min<size_t>(args.localize_from, lasers.size() - 1);
  ls::LocalizationOptions lo;
  if (args.localize_known_start) lo.initial_pose = reference[from].pose;
  if (args.localize_track_nodes > 0) lo.track_query_nodes = args.localize_track_nodes;
  const Clock::time_point build_start = Clock::now();
  absl::StatusOr<std::unique_ptr<ls::MapLocalizer>> localizer = ls::MapLocalizer::Create(lo, *points);
  if (!localizer.ok()) return localizer.status();
  const double build_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - build_start).count();
  ls::SlamOptions plain = options;
  plain.mapping.enabled = false;
  ls::LaserSlam slam(plain, *std::move(localizer));
  std::vector<double> scan_ms, errors, rot_errors, global_ms;
  long first_fix = -1, wrong = 0, localized = 0;
  double first_fix_error = 0;
  for (size_t i = from; i < lasers.size(); ++i) {
    const ls::OdometryReading reading = ToOdometry(lasers[i]);
    const Clock::time_point start = Clock::now();
    (void)slam.AddOdometry(reading);
    absl::StatusOr<ls::ScanUpdate> update = slam.AddScan(ToLaserScan(lasers[i]));
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    scan_ms.push_back(ms);
    if (!update.ok() || !update->localization) continue;
    if (update->localization->global_search) global_ms.push_back(ms);
    if (!update->localization->localized) continue;
    ++localized;
    const ls::Pose2& truth = reference[i].pose;
    const double e = std::hypot(update->pose.pose.x - truth.x, update->pose.pose.y - truth.y);
    const double r = std::abs(std::remainder(update->pose.pose.theta - truth.theta, 2 * M_PI));
    if (first_fix < 0) {
      first_fix = static_cast<long>(i - from);
      first_fix_error = e;
    }
    errors.push_back(e);
    rot_errors.push_back(r * 180.0 / M_PI);
    if (e > 0.5) ++wrong;
  }
  // The session's own trajectory at the end (what GetTrajectory returns), against the same truth.
  double final_mean = 0;
  {
    const std::vector<ls::PoseEstimate> final_poses = slam.Trajectory();
    for (size_t k = 0; k < final_poses.size(); ++k) {
      const ls::Pose2& truth = reference[from + k].pose;
      final_mean += std::hypot(final_poses[k].pose.x - truth.x, final_poses[k].pose.y - truth.y) /
                    final_poses.size();
    }
  }
  double mean = 0, rot_mean = 0;
  for (double e : errors) mean += e / errors.size();
  for (double r : rot_errors) rot_mean += r / rot_errors.size();
  const double from_stamp = lasers[from].stamp;
  return nlohmann::json{
      {"from_scan", from},
      {"known_start", args.localize_known_start},
      {"map_points", points->size()},
      {"build_ms", build_ms},
      {"scans", lasers.size() - from},
      {"localized_scans", localized},
      {"first_fix_scans", first_fix},
      {"first_fix_s", first_fix < 0 ? -1.0 : lasers[from + first_fix].stamp - from_stamp},
      {"first_fix_error_m", first_fix_error},
      {"error_mean_m", mean},
      {"final_trajectory_error_mean_m", final_mean},
      {"error_p95_m", Percentile(errors, 0.95)},
      {"error_max_m", errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end())},
      {"rot_error_mean_deg", rot_mean},
      {"scans_off_by_more_than_0.5m", wrong},
      {"scan_ms_p50", Percentile(scan_ms, 0.5)},
      {"scan_ms_p99", Percentile(scan_ms, 0.99)},
      {"global_search_ms_p50", Percentile(global_ms, 0.5)},
      {"global_searches", global_ms.size()}};
}

int Run(const Args& args) {
  auto read = ReadLasers(args.log);
  if (!read.ok()) {
    std::cerr << args.log << ": " << read.status() << "\n";
    return 1;
  }
  LogLasers& log = *read;
  if (log.malformed > 0) {
    std::cerr << "warning: skipped " << log.malformed << " malformed line(s)";
    for (const std::string& e : log.first_errors) std::cerr << "\n  " << e;
    std::cerr << "\n";
  }
  if (log.lasers.empty()) {
    std::cerr << args.log << ": no laser lines (FLASER or ROBOTLASER1)\n";
    return 1;
  }
  // Before any start is cut: the lag is the whole log's, as a replay's is.
  const adapters::OdometryLag lag = adapters::EstimateOdometryLag(log.lasers);
  const double applied_lag = args.odometry_lag_auto ? lag.lag_scans : args.odometry_lag;
  adapters::ShiftOdometry(applied_lag, &log.lasers);
  if (lag.decided()) {
    std::cerr << "note: " << adapters::DescribeOdometryLag(lag) << ": "
              << (applied_lag == lag.lag_scans ? std::string("moved back (--odometry-lag 0: as logged)")
                                               : absl::StrFormat("--odometry-lag %g given", applied_lag))
              << "\n";
  }
  if (args.start_fraction > 0.0) {
    // A robot starting mid-log (as `waymark slam replay --scans FIRST:` sends it): the same
    // building from another start, to see whether a result holds or was the start's luck.
    const auto first =
        static_cast<long>(args.start_fraction * static_cast<double>(log.lasers.size()));
    log.lasers.erase(log.lasers.begin(), log.lasers.begin() + first);
  }
  if (args.max_scans > 0 && static_cast<size_t>(args.max_scans) < log.lasers.size()) {
    log.lasers.resize(args.max_scans);
  }
  const double rss_after_load_mb = waymark::bench::ResidentMb();

  ls::SlamOptions options = args.options;
  const cli::Pose2 mount = cli::LaserMount(log.lasers.front());
  options.laser_pose = {mount.x, mount.y, mount.theta};
  if (absl::Status s = ls::ValidateSlamOptions(options); !s.ok()) {
    std::cerr << "options: " << s << "\n";
    return 1;
  }
  auto engine = std::make_unique<ls::LaserSlam>(options);
  // Not timed as the engine's: what the self-check would add after every optimisation.
  std::optional<OptimisationChecks> optimisation_checks;
  if (!args.check_after_optimisations.empty()) {
    optimisation_checks.emplace(options.mapping.submap_nodes,
                                args.check_after_optimisations == "incremental");
  }

  std::vector<double> scan_ms;
  std::map<int, std::vector<double>> bin_ms;  // bin index -> per-scan ms (processed scans only)
  std::vector<cli::StampedPose> odometry;     // embedded odometry at every scan stamp
  int64_t rejected = 0, skipped_motion = 0;
  int max_active = 0, max_state = 0;
  std::vector<std::string> rejections;
  double engine_s = 0;
  int resumes = 0;
  for (size_t line = 0; line < log.lasers.size(); ++line) {
    if (args.resume_every > 0 && line > 0 && line % args.resume_every == 0) {
      // What a server restart does (untimed): the session from its checkpoint and its stored
      // local trajectory. The final trajectory should not depend on where this happened.
      absl::StatusOr<std::unique_ptr<ls::LaserSlam>> resumed = ls::LaserSlam::FromCheckpoint(
          options, engine->SerializeState(), engine->LocalTrajectory());
      if (!resumed.ok()) {
        std::cerr << "resume at line " << line << ": " << resumed.status() << "\n";
        return 1;
      }
      engine = *std::move(resumed);
      ++resumes;
    }
    ls::LaserSlam& slam = *engine;
    CarmenLaser& laser = log.lasers[line];
    const ls::OdometryReading reading = ToOdometry(laser);
    odometry.push_back({laser.stamp, {reading.pose.x, reading.pose.y, reading.pose.theta}});
    const ls::LaserScan scan = ToLaserScan(laser);  // the log is kept for a --localize pass
    const Clock::time_point start = Clock::now();
    absl::Status odom_status = slam.AddOdometry(reading);
    absl::StatusOr<ls::ScanUpdate> update = slam.AddScan(scan);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    engine_s += ms / 1000.0;
    scan_ms.push_back(ms);
    if (optimisation_checks && slam.backend() != nullptr) {
      if (absl::Status s = optimisation_checks->AfterScan(*slam.backend()); !s.ok()) {
        std::cerr << "self-check: " << s << "\n";
        return 1;
      }
    }
    if (!odom_status.ok() || !update.ok()) {
      ++rejected;
      if (rejections.size() < 5) {
        rejections.push_back(absl::StrFormat("stamp %.6f: %s", laser.stamp,
                                             (!odom_status.ok() ? odom_status : update.status())
                                                 .ToString()));
      }
      continue;
    }
    if (update->skipped) {
      ++skipped_motion;
      continue;
    }
    max_active = std::max(max_active, update->active_segments);
    max_state = std::max(max_state, update->state_size);
    bin_ms[update->active_segments / kBinWidth].push_back(ms);
  }
  for (const std::string& r : rejections) std::cerr << "warning: rejected " << r << "\n";
  ls::LaserSlam& slam = *engine;
  {
    // The last optimisation belongs to the run's cost.
    const Clock::time_point start = Clock::now();
    slam.FlushBackend();
    engine_s += std::chrono::duration<double, std::milli>(Clock::now() - start).count() / 1000.0;
  }

  const double duration_s = log.lasers.back().stamp - log.lasers.front().stamp;
  std::vector<cli::StampedPose> trajectory;
  for (const ls::PoseEstimate& p : slam.Trajectory()) {
    trajectory.push_back({p.stamp, {p.pose.x, p.pose.y, p.pose.theta}});
  }
  const std::vector<ls::MapSegment> map = slam.Map();
  int active_final = 0;
  for (const ls::MapSegment& s : map) active_final += s.active ? 1 : 0;

  nlohmann::json j = {
      {"log", args.log},
      {"scans", log.lasers.size()},
      {"scans_processed", slam.scans_processed()},
      {"scans_skipped_motion", skipped_motion},
      {"rejected", rejected},
      {"resumes_from_checkpoint", resumes},
      // FNV-1a of the final checkpoint bytes: equal digests = bit-identical sessions (EKF and
      // pose graph), e.g. with and without --resume-every.
      {"final_state_digest", StateDigest(slam.SerializeState())},
      {"duplicate_stamps", log.duplicate_stamps},
      {"odometry_lag",
       {{"applied_scans", applied_lag},
        {"estimated_scans", lag.lag_scans},
        {"turning_pairs", lag.turning_pairs},
        {"pairs_for_lag", lag.for_lag},
        {"pairs_for_in_step", lag.for_in_step},
        {"log10_chance", lag.log10_chance}}},
      {"reordered_lines", log.out_of_order},
      {"malformed_lines", log.malformed},
      {"trajectory_poses", trajectory.size()},
      {"log_duration_s", duration_s},
      {"engine_s", engine_s},
      {"realtime_factor", engine_s > 0 ? duration_s / engine_s : 0.0},
      {"scan_ms_p50", Percentile(scan_ms, 0.5)},
      {"scan_ms_p90", Percentile(scan_ms, 0.9)},
      {"scan_ms_p99", Percentile(scan_ms, 0.99)},
      {"scan_ms_max", scan_ms.empty() ? 0.0 : *std::max_element(scan_ms.begin(), scan_ms.end())},
      {"segments", map.size()},
      {"active_segments", active_final},
      {"max_active_segments_seen", max_active},
      {"max_state_size", max_state},
      {"peak_rss_mb", PeakRssMb()},
      {"rss_after_load_mb", rss_after_load_mb},
      {"options",
       {{"max_active_segments", options.ekf.max_active_segments},
        {"active_radius", options.ekf.active_radius},
        {"freeze_after_scans", options.ekf.freeze_after_scans},
        {"min_travel", options.ekf.min_travel},
        {"min_turn", options.ekf.min_turn},
        {"match_chi2", options.ekf.match_chi2},
        {"laser_pose", {mount.x, mount.y, mount.theta}}}},
  };
  nlohmann::json bins = nlohmann::json::array();
  for (const auto& [bin, values] : bin_ms) {
    bins.push_back({{"active_from", bin * kBinWidth},
                    {"active_to", bin * kBinWidth + kBinWidth - 1},
                    {"count", values.size()},
                    {"p50_ms", Percentile(values, 0.5)},
                    {"p99_ms", Percentile(values, 0.99)}});
  }
  j["by_active_segments"] = bins;
  std::optional<MapCheck> map_check;  // the map's self-check, on the final graph
  if (slam.backend() != nullptr) {
    j["mapping"] = MappingJson(*slam.backend());
    absl::StatusOr<MapCheck> check =
        RunMapCheck(slam.backend()->Nodes(), options.mapping.submap_nodes);
    if (!check.ok()) {
      std::cerr << "self-check: " << check.status() << "\n";
      return 1;
    }
    j["self_check"] = MapCheckJson(*check);
    if (optimisation_checks) j["self_check"]["after_optimisations"] = optimisation_checks->Json();
    map_check = *std::move(check);
    if (!args.save_nodes.empty()) {
      if (absl::Status s = WriteNodesFile(args.save_nodes, slam.backend()->Nodes(),
                                          options.mapping.submap_nodes);
          !s.ok()) {
        std::cerr << s << "\n";
        return 1;
      }
    }
    if (!args.save_closures.empty()) {
      if (absl::Status s = WriteClosuresFile(args.save_closures, slam.backend()->Nodes(),
                                             slam.backend()->Constraints());
          !s.ok()) {
        std::cerr << s << "\n";
        return 1;
      }
    }
    if (!args.picture.empty()) {
      if (absl::Status s = WriteSmallCheckedPicture(args.picture, slam.backend()->Nodes(),
                                                    *map_check, args.picture_size);
          !s.ok()) {
        std::cerr << s << "\n";
        return 1;
      }
    }
  }
  if (args.localize) {
    absl::StatusOr<nlohmann::json> localization = RunLocalization(args, options, log.lasers, slam);
    if (!localization.ok()) {
      std::cerr << "localization: " << localization.status() << "\n";
      return 1;
    }
    j["localization"] = *localization;
    std::cout << "localization: " << localization->dump() << "\n";
  }

  std::vector<std::string> metric_lines;
  if (!args.relations.empty()) {
    auto relations = cli::ReadRelationsFile(args.relations);
    if (!relations.ok()) {
      std::cerr << args.relations << ": " << relations.status() << "\n";
      return 1;
    }
    std::vector<cli::Relation> local;
    for (const cli::Relation& r : *relations) {
      if (std::abs(r.t2 - r.t1) <= kLocalRelationS) local.push_back(r);
    }
    // The odometry at the stamps the SLAM trajectory has (the same poses, had no scan failed).
    std::vector<cli::StampedPose> odom_at_slam;
    {
      size_t k = 0;
      for (const cli::StampedPose& p : trajectory) {
        while (k < odometry.size() && odometry[k].stamp < p.stamp) ++k;
        if (k < odometry.size() && odometry[k].stamp == p.stamp) odom_at_slam.push_back(odometry[k]);
      }
    }
    const cli::RelationsResult slam_all = cli::EvaluateRelations(trajectory, *relations);
    const cli::RelationsResult odom_all = cli::EvaluateRelations(odom_at_slam, *relations);
    const cli::RelationsResult slam_local = cli::EvaluateRelations(trajectory, local);
    const cli::RelationsResult odom_local = cli::EvaluateRelations(odom_at_slam, local);
    j["relations"] = {{"file", args.relations},
                      {"local_max_dt_s", kLocalRelationS},
                      {"slam", MetricJson(slam_all)},
                      {"odometry", MetricJson(odom_all)},
                      {"slam_local", MetricJson(slam_local)},
                      {"odometry_local", MetricJson(odom_local)}};
    metric_lines = {"  slam      all   " + MetricLine(slam_all),
                    "  odometry  all   " + MetricLine(odom_all),
                    "  slam      local " + MetricLine(slam_local),
                    "  odometry  local " + MetricLine(odom_local)};
  }

  if (!args.out.empty()) {
    const std::filesystem::path dir(args.out);
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) {
      std::cerr << "cannot create " << dir << ": " << ec.message() << "\n";
      return 1;
    }
    for (const auto& [name, poses] : {std::pair<const char*, const std::vector<cli::StampedPose>*>{
                                          "trajectory.txt", &trajectory},
                                      {"odometry.txt", &odometry}}) {
      if (absl::Status s = cli::WriteTumFile(dir / name, *poses); !s.ok()) {
        std::cerr << s << "\n";
        return 1;
      }
    }
    cli::MapScene scene;
    scene.title = absl::StrFormat("%s: %d scans, %d segments (engine only)",
                                  cli::LogName(args.log), log.lasers.size(), map.size());
    for (const ls::MapSegment& s : map) scene.segments.push_back(SceneOf(s));
    cli::ScenePolyline path;
    path.color = {30, 150, 60};
    path.label = "trajectory";
    for (const cli::StampedPose& p : trajectory) path.points.push_back({p.pose.x, p.pose.y});
    const std::vector<cli::Vec2> path_points = path.points;
    scene.polylines.push_back(std::move(path));
    if (map_check) {
      for (cli::ScenePolyline& mark : ContradictionPolylines(*map_check)) {
        scene.polylines.push_back(std::move(mark));
      }
    }
    if (absl::Status s = cli::WriteMapPictures(scene, dir / "map.svg", dir / "map.png"); !s.ok()) {
      std::cerr << s << "\n";
      return 1;
    }
    if (map_check) {
      if (absl::Status s = WriteCheckedOccupancyPicture(dir / "occupancy.png",
                                                        slam.backend()->Nodes(), *map_check,
                                                        path_points);
          !s.ok()) {
        std::cerr << s << "\n";
        return 1;
      }
    }
    j["out_dir"] = dir.string();
    std::ofstream summary(dir / "summary.json");
    summary << j.dump(2) << "\n";
    if (!summary) {
      std::cerr << "cannot write " << (dir / "summary.json") << "\n";
      return 1;
    }
  }

  if (args.json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << absl::StrFormat(
      "%s: %d scans (%d duplicate stamps dropped, %d lines reordered, %d rejected, %d skipped "
      "for motion)\n"
      "log %.1f s, engine %.2f s: real-time factor %.1fx\n"
      "per scan: p50 %.2f ms  p90 %.2f ms  p99 %.2f ms  max %.2f ms\n"
      "segments: %d (%d active at the end, at most %d active, state size up to %d); peak RSS "
      "%.1f MB (%.1f MB after loading the log)\n",
      args.log, log.lasers.size(), log.duplicate_stamps, log.out_of_order, rejected,
      skipped_motion, duration_s, engine_s, engine_s > 0 ? duration_s / engine_s : 0.0,
      j["scan_ms_p50"].get<double>(), j["scan_ms_p90"].get<double>(),
      j["scan_ms_p99"].get<double>(), j["scan_ms_max"].get<double>(), map.size(), active_final,
      max_active, max_state, j["peak_rss_mb"].get<double>(), rss_after_load_mb);
  std::cout << "per scan by active segments (processed scans):\n";
  for (const auto& [bin, values] : bin_ms) {
    std::cout << absl::StrFormat("  %4d-%-4d  %6d scans  p50 %7.2f ms  p99 %7.2f ms\n",
                                 bin * kBinWidth, bin * kBinWidth + kBinWidth - 1, values.size(),
                                 Percentile(values, 0.5), Percentile(values, 0.99));
  }
  if (!metric_lines.empty()) {
    if (j.contains("mapping")) std::cout << "loop closure: " << j["mapping"].dump() << "\n";
    std::cout << "relations metric (local: t2 - t1 <= " << kLocalRelationS << " s):\n";
    for (const std::string& line : metric_lines) std::cout << line << "\n";
  }
  if (map_check) {
    std::cout << absl::StrFormat("self-check (%.0f ms): %s\n", map_check->check_ms,
                                 map_check->report.verdict);
  }
  if (!args.out.empty()) {
    std::cout << "wrote " << args.out << "/trajectory.txt, odometry.txt, map.svg, map.png, "
              << (map_check ? "occupancy.png, " : "") << "summary.json\n";
  }
  return 0;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  waymark::bench::Args args;
  if (!waymark::bench::ParseArgs(argc, argv, &args)) {
    waymark::bench::Usage();
    return 2;
  }
  return waymark::bench::Run(args);
}
