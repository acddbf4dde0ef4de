#include "client/sessions/slam_replay.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/datasets/carmen_log.h"
#include "client/robot/laser_session.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/eval/relations_metric.h"
#include "client/render/slam_output.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {
namespace {

using adapters::CarmenLaser;
using adapters::CarmenLogReader;
using adapters::CarmenRecord;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The laser lines of a log in stamp order. Lines are reordered within a lookahead of
// kReorderWindow laser lines (see slam_replay.h: the Intel log has FLASER lines up to 14 lines
// out of place, none duplicated); a line whose stamp is still not above the last one emitted (a
// duplicate, or later than the lookahead) is skipped and counted.
class LaserFeed {
 public:
  static constexpr size_t kReorderWindow = 64;

  explicit LaserFeed(std::unique_ptr<CarmenLogReader> reader) : reader_(std::move(reader)) {}

  // The next usable laser record; false at the end of the log.
  absl::StatusOr<bool> Next(CarmenRecord* record) {
    while (true) {
      while (!eof_ && pending_.size() <= kReorderWindow) {
        CarmenRecord next;
        auto more = reader_->Next(&next);
        if (!more.ok()) return more.status();
        if (!*more) {
          eof_ = true;
          break;
        }
        if (next.type == CarmenRecord::Type::kOdometry) {
          ++odometry_lines_;
          continue;
        }
        if (have_read_ && next.laser.stamp < max_read_) ++out_of_order_;
        max_read_ = have_read_ ? std::max(max_read_, next.laser.stamp) : next.laser.stamp;
        have_read_ = true;
        pending_.push_back(std::move(next));
        std::push_heap(pending_.begin(), pending_.end(), Later);
      }
      if (pending_.empty()) return false;
      std::pop_heap(pending_.begin(), pending_.end(), Later);
      *record = std::move(pending_.back());
      pending_.pop_back();
      if (have_last_ && !(record->laser.stamp > last_stamp_)) {
        ++skipped_stamps_;
        continue;
      }
      have_last_ = true;
      last_stamp_ = record->laser.stamp;
      return true;
    }
  }

  CarmenLogReader& reader() { return *reader_; }
  int64_t odometry_lines() const { return odometry_lines_; }
  int64_t skipped_stamps() const { return skipped_stamps_; }
  int64_t out_of_order() const { return out_of_order_; }

 private:
  static bool Later(const CarmenRecord& a, const CarmenRecord& b) {
    return a.laser.stamp > b.laser.stamp || (a.laser.stamp == b.laser.stamp && a.line > b.line);
  }

  std::unique_ptr<CarmenLogReader> reader_;
  std::vector<CarmenRecord> pending_;  // min-heap by stamp (then line)
  bool eof_ = false;
  bool have_read_ = false;
  double max_read_ = 0;
  bool have_last_ = false;
  double last_stamp_ = 0;
  int64_t odometry_lines_ = 0;
  int64_t skipped_stamps_ = 0;
  int64_t out_of_order_ = 0;
};

v1::LaserGeometry GeometryOf(const CarmenLaser& laser) {
  v1::LaserGeometry geometry;
  geometry.set_angle_min(laser.angle_min);
  geometry.set_angle_increment(laser.angle_increment);
  geometry.set_beam_count(static_cast<uint32_t>(laser.ranges.size()));
  geometry.set_no_return_range(laser.no_return_range);
  return geometry;
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t index = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5));
  return values[index];
}

void PrintReadProblems(CommandContext& context, CarmenLogReader& reader) {
  if (reader.malformed_lines() == 0) return;
  context.err << "warning: skipped " << reader.malformed_lines() << " malformed line(s)";
  for (const std::string& error : reader.first_errors()) context.err << "\n  " << error;
  context.err << "\n";
}

}  // namespace

// See the header: the laser's mounting from the first line, when plausible.
Pose2 LaserMount(const CarmenLaser& laser) {
  const Pose2 odom{laser.odom_pose.x, laser.odom_pose.y, laser.odom_pose.theta};
  const Pose2 sensor{laser.laser_pose.x, laser.laser_pose.y, laser.laser_pose.theta};
  const Pose2 mount = Compose(Inverse(odom), sensor);
  if (std::hypot(mount.x, mount.y) < 1.0 && std::abs(mount.theta) < 0.1) return mount;
  return {};
}

std::string LogName(const std::string& path) {
  std::filesystem::path name = std::filesystem::path(path).filename();
  while (true) {
    const std::string ext = name.extension().string();
    if (ext == ".bz2" || ext == ".gz" || ext == ".clf" || ext == ".log" || ext == ".txt") {
      name = name.stem();
    } else {
      break;
    }
  }
  return name.empty() ? "log" : name.string();
}

int RunSlamReplay(CommandContext& context, const ReplayArgs& args) {
  auto reader = CarmenLogReader::Open(args.log);
  if (!reader.ok()) return ReportError(context, reader.status());
  LaserFeed feed(*std::move(reader));
  const std::filesystem::path out_dir =
      args.out_dir.empty() ? std::filesystem::path("out") / LogName(args.log)
                           : std::filesystem::path(args.out_dir);

  CarmenRecord record;
  auto first = feed.Next(&record);
  if (!first.ok()) return ReportError(context, first.status(), args.log);
  if (!*first) {
    PrintReadProblems(context, feed.reader());
    return ReportError(context, absl::InvalidArgumentError(
                                    "the log has no laser lines (FLASER or ROBOTLASER1)"),
                       args.log);
  }

  std::unique_ptr<client::SlamClient> client = context.ConnectSlam();
  v1::CreateSessionRequest create;
  create.set_robot_id(args.robot_id);
  create.set_name(args.name.empty() ? "replay of " + LogName(args.log) : args.name);
  v1::LaserSlamConfig* config = create.mutable_laser();
  *config->mutable_laser() = GeometryOf(record.laser);
  const Pose2 mount = LaserMount(record.laser);
  config->mutable_laser_pose()->set_x(mount.x);
  config->mutable_laser_pose()->set_y(mount.y);
  config->mutable_laser_pose()->set_theta(mount.theta);
  v1::LaserSlamParams* params = config->mutable_params();
  if (args.max_range) params->set_max_range(*args.max_range);
  if (args.odom_xy_per_m) params->set_odom_xy_per_m(*args.odom_xy_per_m);
  if (args.odom_theta_per_rad) params->set_odom_theta_per_rad(*args.odom_theta_per_rad);
  if (args.odom_theta_per_m) params->set_odom_theta_per_m(*args.odom_theta_per_m);
  if (args.match_chi2) params->set_match_chi2(*args.match_chi2);
  auto session = client->CreateSession(create);
  if (!session.ok()) return ReportError(context, session.status(), "CreateSession");
  const std::string session_id = session->session_id();

  // Answers arrive on the stream's reader thread.
  std::mutex updates_mutex;
  std::vector<double> server_ms;
  uint64_t skipped_motion = 0;
  std::vector<std::string> rejections;
  auto on_update = [&](const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(updates_mutex);
    if (update.has_rejection()) {
      if (rejections.size() < 5) {
        rejections.push_back(fmt::format("message {}: code {}: {}", update.sequence(),
                                         update.rejection().code(), update.rejection().message()));
      }
      return;
    }
    if (update.skipped()) ++skipped_motion;
    server_ms.push_back(update.timings().total_ms());
  };
  std::unique_ptr<client::SensorStream> stream =
      client->StreamSensorData(session_id, args.window, on_update);

  const bool by_scans = args.max_scans > 0;
  const int64_t kib_total = std::max<int64_t>(1, feed.reader().file_size() / 1024);
  ProgressBar progress(context.err,
                       by_scans ? args.max_scans : static_cast<int>(kib_total),
                       by_scans ? "scans" : "KiB of log", context.err_is_tty);
  const double first_stamp = record.laser.stamp;
  double last_stamp = first_stamp;
  int64_t scans_sent = 0;
  std::vector<Vec2> odometry_path;
  const Clock::time_point start = Clock::now();
  absl::Status failure;
  for (bool more = true; more;) {
    if (args.realtime) {
      const auto due = start + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(record.laser.stamp - first_stamp));
      std::this_thread::sleep_until(due);
    }
    v1::Odometry odometry;
    odometry.set_stamp(record.laser.stamp);
    *odometry.mutable_pose() = ToProto(record.laser.odom_pose);
    v1::LaserScan scan;
    scan.set_stamp(record.laser.stamp);
    *scan.mutable_geometry() = GeometryOf(record.laser);
    scan.mutable_ranges()->Assign(record.laser.ranges.begin(), record.laser.ranges.end());
    if (failure = stream->SendOdometry(odometry); failure.ok()) failure = stream->SendScan(scan);
    if (!failure.ok()) break;
    ++scans_sent;
    last_stamp = record.laser.stamp;
    if (args.show_odometry) {
      odometry_path.push_back({record.laser.odom_pose.x, record.laser.odom_pose.y});
    }
    if (scans_sent % 16 == 0) {
      progress.Update(by_scans ? static_cast<int>(scans_sent)
                               : static_cast<int>(feed.reader().bytes_consumed() / 1024));
    }
    if (by_scans && scans_sent >= args.max_scans) break;
    auto next = feed.Next(&record);
    if (!next.ok()) {
      failure = next.status();
      break;
    }
    more = *next;
  }
  const absl::Status finished = stream->Finish();
  const double processing_s = SecondsSince(start);
  progress.Update(by_scans ? static_cast<int>(scans_sent) : static_cast<int>(kib_total));
  progress.Finish();
  const client::SensorStream::Stats stats = stream->stats();
  PrintReadProblems(context, feed.reader());
  if (!failure.ok() && failure.code() != absl::StatusCode::kUnavailable) {
    return ReportError(context, failure, args.log);
  }
  if (!finished.ok()) {
    return ReportError(context, finished, "stream of session " + session_id);
  }
  for (const std::string& r : rejections) context.err << "warning: rejected " << r << "\n";

  auto closed = client->CloseSession(session_id);
  if (!closed.ok()) return ReportError(context, closed.status(), "CloseSession " + session_id);
  auto trajectory = client->GetTrajectory(session_id);
  if (!trajectory.ok()) return ReportError(context, trajectory.status(), "GetTrajectory");
  auto map = client->GetMap(session_id);
  if (!map.ok()) return ReportError(context, map.status(), "GetMap");
  if (absl::Status s = WriteSlamFiles(out_dir, *map, *trajectory,
                                      fmt::format("{}: {} scans, {} segments", LogName(args.log),
                                                  stats.updates, map->segments_size()),
                                      odometry_path);
      !s.ok()) {
    return ReportError(context, s, out_dir.string());
  }

  const double log_duration_s = last_stamp - first_stamp;
  nlohmann::json summary = {
      {"log", args.log},
      {"session_id", session_id},
      {"scans", stats.updates},
      {"scans_sent", stats.scans_sent},
      {"scans_skipped_motion", skipped_motion},
      {"rejected", stats.scans_rejected + stats.odometry_rejected},
      {"queue_full", stats.queue_full},
      {"skipped_stamps", feed.skipped_stamps()},
      {"reordered_lines", feed.out_of_order()},
      {"malformed_lines", feed.reader().malformed_lines()},
      {"odometry_lines_not_sent", feed.odometry_lines()},
      {"segments", map->segments_size()},
      {"map_revision", map->map_revision()},
      {"trajectory_poses", trajectory->poses_size()},
      {"processing_s", processing_s},
      {"log_duration_s", log_duration_s},
      {"realtime_factor", processing_s > 0 ? log_duration_s / processing_s : 0.0},
      {"window", stream->window()},
      {"max_outstanding", stats.max_outstanding},
      {"server_ms_p50", Percentile(server_ms, 0.5)},
      {"server_ms_p99", Percentile(server_ms, 0.99)},
      {"realtime", args.realtime},
      {"out_dir", out_dir.string()},
  };
  {
    std::ofstream out(out_dir / "summary.json");
    out << summary.dump(2) << "\n";
    if (!out) return ReportError(context, absl::DataLossError("cannot write summary.json"));
  }
  if (context.globals.json) {
    PrintJson(context.out, summary);
  } else {
    context.out << fmt::format(
        "session {}: {} scans processed ({} sent, {} rejected, {} skipped stamps), {} segments\n"
        "log {:.1f} s replayed in {:.2f} s: real-time factor {:.1f}x; server p50 {:.2f} ms, "
        "p99 {:.2f} ms per scan\n"
        "wrote {}/trajectory.txt, map.svg, map.png, summary.json\n",
        session_id, stats.updates, stats.scans_sent, stats.scans_rejected + stats.odometry_rejected,
        feed.skipped_stamps(), map->segments_size(), log_duration_s, processing_s,
        processing_s > 0 ? log_duration_s / processing_s : 0.0, Percentile(server_ms, 0.5),
        Percentile(server_ms, 0.99), out_dir.string());
  }
  return kExitOk;
}

int RunSlamOdometry(CommandContext& context, const OdometryArgs& args) {
  auto reader = CarmenLogReader::Open(args.log);
  if (!reader.ok()) return ReportError(context, reader.status());
  LaserFeed feed(*std::move(reader));
  std::vector<StampedPose> poses;
  CarmenRecord record;
  while (args.max_scans <= 0 || static_cast<int>(poses.size()) < args.max_scans) {
    auto more = feed.Next(&record);
    if (!more.ok()) return ReportError(context, more.status(), args.log);
    if (!*more) break;
    const auto& p = record.laser.odom_pose;
    poses.push_back({record.laser.stamp, {p.x, p.y, p.theta}});
  }
  PrintReadProblems(context, feed.reader());
  if (absl::Status s = WriteTumFile(args.out, poses); !s.ok()) return ReportError(context, s);
  if (context.globals.json) {
    PrintJson(context.out, {{"log", args.log},
                            {"out", args.out},
                            {"poses", poses.size()},
                            {"skipped_stamps", feed.skipped_stamps()},
                            {"reordered_lines", feed.out_of_order()},
                            {"malformed_lines", feed.reader().malformed_lines()}});
  } else {
    context.out << "wrote " << poses.size() << " odometry poses to " << args.out << " ("
                << feed.out_of_order() << " laser lines reordered by stamp, "
                << feed.skipped_stamps() << " with a repeated stamp skipped)\n";
  }
  return kExitOk;
}

}  // namespace waymark::cli
