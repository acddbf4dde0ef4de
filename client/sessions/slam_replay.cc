#include "client/sessions/slam_replay.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/datasets/carmen_log.h"
#include "client/datasets/tum_trajectory.h"
#include "client/eval/eval_metrics.h"      // Percentile
#include "client/eval/relations_metric.h"  // Compose, Inverse
#include "client/render/occupancy_picture.h"
#include "client/render/slam_output.h"
#include "client/robot/laser_session.h"
#include "client/sessions/replay_report.h"
#include "client/sessions/session_grid.h"

namespace waymark::cli {
namespace {

using adapters::CarmenLaser;
using adapters::CarmenLaserFeed;
using adapters::CarmenLogReader;
using adapters::CarmenRecord;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string StatusText(const absl::Status& status) {
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message());
}

void PrintReadProblems(CommandContext& context, CarmenLogReader& reader) {
  if (reader.malformed_lines() == 0) return;
  context.err << "warning: skipped " << reader.malformed_lines() << " malformed line(s)";
  for (const std::string& error : reader.first_errors()) context.err << "\n  " << error;
  context.err << "\n";
}

absl::StatusOr<std::unique_ptr<CarmenLaserFeed>> OpenFeed(const std::string& log, bool restamp,
                                                          double rate_hz) {
  auto reader = CarmenLogReader::Open(log);
  if (!reader.ok()) return reader.status();
  adapters::LaserFeedOptions options;
  if (restamp) options.restamp_rate_hz = rate_hz;
  return std::make_unique<CarmenLaserFeed>(*std::move(reader), options);
}

// The laser scans a replay of `log` sends when it is not stopped: the log read through a feed of
// its own with the same options, so scans skipped for their stamps are not counted. For the
// progress bar, which follows the scans sent (the reader itself reads ahead of what was sent: a
// compressed log can be read whole while the first scans go out). 0 when the log cannot be read.
// Gives up (0) once `cancel` is set.
int64_t CountFeedScans(const std::string& log, bool restamp, double rate_hz,
                       const std::atomic<bool>* cancel) {
  auto feed = OpenFeed(log, restamp, rate_hz);
  if (!feed.ok()) return 0;
  CarmenRecord record;
  int64_t scans = 0;
  while (!cancel->load()) {
    auto next = (*feed)->Next(&record);
    if (!next.ok() || !*next) break;
    ++scans;
  }
  return scans;
}

// The replay's progress bar: scans sent of the scans in the log (or of --max-scans), drawn once
// the log has been counted on a thread of its own (a bar with a total, never one of bytes read).
class ReplayProgress {
 public:
  ReplayProgress(CommandContext& context, const ReplayArgs& args)
      : context_(context), max_scans_(args.max_scans) {
    if (!context.err_is_tty) return;  // the bar is for a person watching
    total_ = std::async(std::launch::async, CountFeedScans, args.log, args.restamp, args.rate_hz,
                        &cancel_);
  }
  ~ReplayProgress() { cancel_ = true; }  // the future's destructor then waits little
  // `sent` scans sent, `answered` answered so far. `final`: waits for the count.
  void Update(int64_t sent, int64_t answered, bool final = false) {
    if (!total_.valid() && !bar_) return;
    if (!bar_) {
      if (!final && total_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
      int64_t total = total_.get();
      if (max_scans_ > 0) total = std::min<int64_t>(total, max_scans_);
      bar_.emplace(context_.err, static_cast<int>(std::max<int64_t>(total, 1)), "scans",
                   context_.err_is_tty);
    }
    bar_->Update(static_cast<int>(sent), fmt::format("{} answered", answered));
  }
  void Finish() {
    if (bar_) bar_->Finish();
  }

 private:
  CommandContext& context_;
  const int max_scans_;
  std::atomic<bool> cancel_{false};
  std::future<int64_t> total_;
  std::optional<ProgressBar> bar_;
};

// The loud warning when most laser lines were skipped for their stamps (how many, why, what to
// do); empty when the stamps were usable.
std::string BrokenStampsWarning(const CarmenLaserFeed& feed) {
  if (!feed.StampsBroken()) return "";
  const int64_t skipped = feed.skipped_stamps();
  const int64_t earlier = skipped - feed.repeated_stamps();
  std::vector<std::string> why;
  if (feed.repeated_stamps() > 0) {
    why.push_back(fmt::format("{} repeat the stamp {:.10g} of a line before them",
                              feed.repeated_stamps(), feed.last_repeated_stamp()));
  }
  if (earlier > 0) {
    why.push_back(fmt::format("{} are earlier than a line more than {} laser lines before them",
                              earlier, CarmenLaserFeed::kReorderWindow));
  }
  return fmt::format(
      "WARNING: {} of {} laser lines ({:.1f}%) were skipped because their stamps do not increase "
      "({}): this log's stamps are broken, and only {} scans were used.\n"
      "WARNING: run it again with --restamp to stamp the scans from their order in the log (at "
      "{:g} Hz, or --rate HZ).\n",
      skipped, feed.laser_lines(), 100.0 * static_cast<double>(skipped) / feed.laser_lines(),
      fmt::join(why, "; "), feed.laser_lines() - skipped, adapters::kDefaultRestampRateHz);
}

// What the stream's answers say, gathered on its reader thread; read once the stream finished.
class Answers {
 public:
  void Add(const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (update.has_rejection()) {
      if (rejections_.size() < 5) {
        rejections_.push_back(fmt::format("message {}: code {}: {}", update.sequence(),
                                          update.rejection().code(),
                                          update.rejection().message()));
      }
      return;
    }
    if (update.skipped()) ++skipped_motion_;
    loop_closures_ = std::max<uint64_t>(loop_closures_, update.loop_closures());
    if (update.has_localization()) ++localization_statuses_;
    if (update.localization().state() == v1::LocalizationStatus::AMBIGUOUS) ++ambiguous_;
    if (update.localization().localized()) {
      ++localized_;
      if (!first_fix_) {
        const v1::LocalizationStatus& l = update.localization();
        first_fix_ = Fix{answered_, update.stamp(), l.score(), l.rival_ratio(), l.rival_distance()};
      }
    }
    ++answered_;
    server_ms_.push_back(update.timings().total_ms());
    // The trajectory as the answers tell it, for when the server cannot be asked afterwards.
    v1::TrajectoryPose* pose = trajectory_.add_poses();
    pose->set_stamp(update.stamp());
    *pose->mutable_pose() = update.pose();
  }

  // The first scan answered localized: its index among the answered scans, its stamp and its
  // confidence (score, and its best rival's score over it and distance from it).
  struct Fix {
    uint64_t scan = 0;
    double stamp = 0;
    double score = 0;
    double rival_ratio = 0;
    double rival_distance = 0;
  };

  std::vector<std::string> rejections() const { return Locked(rejections_); }
  uint64_t localized() const { return Locked(localized_); }
  uint64_t loop_closures() const { return Locked(loop_closures_); }
  uint64_t localization_statuses() const { return Locked(localization_statuses_); }
  uint64_t ambiguous() const { return Locked(ambiguous_); }
  std::optional<Fix> first_fix() const { return Locked(first_fix_); }
  std::vector<double> server_ms() const { return Locked(server_ms_); }
  uint64_t skipped_motion() const { return Locked(skipped_motion_); }
  v1::Trajectory trajectory() const { return Locked(trajectory_); }

 private:
  template <typename T>
  T Locked(const T& value) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return value;
  }

  mutable std::mutex mutex_;
  std::vector<std::string> rejections_;
  std::vector<double> server_ms_;
  uint64_t skipped_motion_ = 0;
  uint64_t answered_ = 0;  // scans answered without a rejection
  uint64_t localized_ = 0;
  uint64_t loop_closures_ = 0;  // the newest count the answers carried
  uint64_t localization_statuses_ = 0;  // answers that carry a LocalizationStatus
  uint64_t ambiguous_ = 0;  // answers not localized because another place fit nearly as well
  std::optional<Fix> first_fix_;
  v1::Trajectory trajectory_;
};

// Sleeps until `due`, waking every 100 ms to see whether a stop was requested.
void SleepUntil(Clock::time_point due, const StopRequested& stop) {
  constexpr auto kSlice = std::chrono::milliseconds(100);
  while (Clock::now() < due && !(stop && stop())) {
    std::this_thread::sleep_until(std::min(due, Clock::now() + kSlice));
  }
}

// The session's results after the stream: closed, then read back; whatever the server cannot give
// any more comes from the stream's answers (trajectory) or is left out (map) and said so.
struct SessionResults {
  v1::Trajectory trajectory;
  v1::SegmentMap map;
  std::optional<v1::OccupancyGrid> grid;  // only asked for a folder --out, or when localizing
  // Localization: the map localized on, which the pictures draw instead of `map`.
  std::optional<v1::SegmentMap> drawn_map;
};

SessionResults CloseAndCollect(client::SlamClient& client, const std::string& session_id,
                               const Answers& answers, ReplayReport& report) {
  // Closing waits for the server's back end to finish its loop searches and last optimisation:
  // the map is final only then, so that time belongs to the replay's cost.
  const auto close_start = std::chrono::steady_clock::now();
  auto closed = client.CloseSession(session_id);
  report.close_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - close_start).count();
  report.session_closed = closed.ok();
  if (!closed.ok()) report.close_error = StatusText(closed.status());
  SessionResults results;
  auto trajectory = client.GetTrajectory(session_id);
  if (trajectory.ok()) {
    results.trajectory = *std::move(trajectory);
  } else {
    results.trajectory = answers.trajectory();
    results.trajectory.set_session_id(session_id);
    report.trajectory_source = "stream answers (GetTrajectory: " +
                               StatusText(trajectory.status()) + ")";
  }
  auto map = client.GetMap(session_id);
  if (map.ok()) {
    results.map = *std::move(map);
  } else {
    results.map.set_session_id(session_id);
    report.map_problem = "GetMap: " + StatusText(map.status());
  }
  return results;
}

// The grid for a folder --out; whatever keeps it from being had is a note, not a failure.
std::optional<v1::OccupancyGrid> CollectGrid(client::SlamClient& client,
                                             const std::string& session_id,
                                             std::optional<double> resolution,
                                             ReplayReport& report) {
  if (!report.map_problem.empty()) {
    // The server did not answer for the map: asking again would only wait out more retries.
    report.grid_note =
        "no occupancy grid: the server could not be asked (" + report.map_problem + ")";
    return std::nullopt;
  }
  absl::StatusOr<SessionGrid> grid = FetchSessionGrid(client, session_id, resolution);
  if (!grid.ok()) {
    report.grid_note = "no occupancy grid: GetOccupancyGrid: " + StatusText(grid.status());
    return std::nullopt;
  }
  report.grid_note = grid->missing;
  return std::move(grid->grid);
}

// A localization replay draws the map it localized on, `map_id`: its segments, and its occupancy
// grid (the localizer matches scans against the map's scans, which the grid shows) with this
// run's trajectory. This session's own segments and grid are no map (it keeps no scans: asking
// for its grid only says so). What cannot be had is said in the report, never a failure.
void CollectLocalizationMap(client::SlamClient& client, const std::string& map_id,
                            std::optional<double> resolution, SessionResults& results,
                            ReplayReport& report) {
  absl::StatusOr<v1::SegmentMap> map = client.GetMap(map_id);
  if (!map.ok()) {
    report.drawn_map_problem = "GetMap: " + StatusText(map.status());
    return;
  }
  map->clear_self_check();  // that map's own verdict, not this run's
  report.map_drawn = true;
  report.drawn_segments = map->segments_size();
  results.drawn_map = *std::move(map);
  absl::StatusOr<SessionGrid> grid = FetchSessionGrid(client, map_id, resolution);
  if (!grid.ok()) {
    report.grid_note = fmt::format("map {} has no occupancy grid to draw: GetOccupancyGrid: {}",
                                   map_id, StatusText(grid.status()));
  } else if (!grid->grid) {
    report.grid_note = fmt::format("map {} has no occupancy grid to draw ({})", map_id,
                                   grid->missing);
  } else {
    results.grid = std::move(grid->grid);
  }
}

// map.pgm, map.yaml and occupancy.png into the folder; a failure is the grid's note.
void WriteGrid(const std::filesystem::path& dir, const v1::OccupancyGrid& grid,
               const v1::Trajectory& trajectory, ReplayReport& report) {
  auto written =
      WriteGridFiles(dir, grid, trajectory, report.self_check ? &*report.self_check : nullptr);
  if (!written.ok()) {
    report.grid_note = "no occupancy grid files: " + StatusText(written.status());
    return;
  }
  report.files.insert(report.files.end(), written->begin(), written->end());
  report.grid_width = grid.width();
  report.grid_height = grid.height();
  report.grid_resolution = grid.resolution();
}

// The pictures (and trajectory) to `target`, then summary.json into a folder target. Failures go
// to report.write_error.
void WriteOutputs(const SlamOutTarget& target, const SessionResults& results,
                  const std::vector<Vec2>& odometry_path, ReplayReport& report) {
  report.out = target.path;
  report.out_is_folder = target.is_folder();
  report.segments = results.map.segments_size();
  if (results.map.has_self_check()) report.self_check = results.map.self_check();
  if (results.map.graph_nodes() > 0) report.loop_closures = results.map.loop_closures();
  report.map_revision = results.map.map_revision();
  report.trajectory_poses = results.trajectory.poses_size();
  const bool localizing = !report.localize_map.empty();
  std::string title =
      localizing ? fmt::format("{}: {} scans localized on map {}", LogName(report.log),
                               report.scans_answered, report.localize_map)
                 : fmt::format("{}: {} scans, {} segments", LogName(report.log),
                               report.scans_answered, report.segments);
  if (report.partial()) title += fmt::format(" (partial: {})", ReplayEndName(report.end));
  const v1::SegmentMap& drawn = results.drawn_map ? *results.drawn_map : results.map;
  auto written = WriteSlamOutputs(target, drawn, results.trajectory, title, odometry_path);
  if (!written.ok()) {
    report.write_error = StatusText(written.status());
    return;
  }
  report.files = *std::move(written);
  // Localizing on a grid: map.png is that grid with the trajectory (an imported map has no
  // segments at all).
  if (localizing && results.grid && target.kind != SlamOutTarget::Kind::kSvg) {
    const std::filesystem::path png = target.is_folder() ? target.path / "map.png" : target.path;
    std::vector<ScenePolyline> paths;
    if (results.trajectory.poses_size() > 0) {
      paths.push_back(TrajectoryPolyline(results.trajectory));
    }
    if (absl::Status s = WriteOccupancyPicture(png, *results.grid, paths); !s.ok()) {
      report.write_error = StatusText(s);
      return;
    }
    if (!target.is_folder()) {
      report.grid_width = results.grid->width();
      report.grid_height = results.grid->height();
      report.grid_resolution = results.grid->resolution();
    }
  }
  if (!target.is_folder()) return;
  if (results.grid) WriteGrid(target.path, *results.grid, results.trajectory, report);
  const std::filesystem::path summary_path = target.path / "summary.json";
  report.files.push_back(summary_path);  // before writing, so the file lists itself
  std::ofstream out(summary_path);
  out << ReplayJson(report).dump(2) << "\n";
  if (!out) {
    report.files.pop_back();
    report.write_error = "cannot write '" + summary_path.string() + "'";
  }
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

v1::LaserGeometry GeometryOf(const CarmenLaser& laser) {
  v1::LaserGeometry geometry;
  geometry.set_angle_min(laser.angle_min);
  geometry.set_angle_increment(laser.angle_increment);
  geometry.set_beam_count(static_cast<uint32_t>(laser.ranges.size()));
  geometry.set_no_return_range(laser.no_return_range);
  return geometry;
}

ReplayStep ReplayStepOf(const CarmenLaser& laser) {
  ReplayStep step;
  step.odometry.set_stamp(laser.stamp);
  *step.odometry.mutable_pose() = ToProto(laser.odom_pose);
  step.scan.set_stamp(laser.stamp);
  *step.scan.mutable_geometry() = GeometryOf(laser);
  step.scan.mutable_ranges()->Assign(laser.ranges.begin(), laser.ranges.end());
  return step;
}

v1::CreateSessionRequest SessionRequest(const ReplayArgs& args, const CarmenLaser& first) {
  v1::CreateSessionRequest create;
  create.set_robot_id(args.robot_id);
  create.set_name(args.name.empty() ? "replay of " + LogName(args.log) : args.name);
  v1::LaserSlamConfig* config = create.mutable_laser();
  *config->mutable_laser() = GeometryOf(first);
  const Pose2 mount = LaserMount(first);
  config->mutable_laser_pose()->set_x(mount.x);
  config->mutable_laser_pose()->set_y(mount.y);
  config->mutable_laser_pose()->set_theta(mount.theta);
  v1::LaserSlamParams* params = config->mutable_params();
  if (args.max_range) params->set_max_range(*args.max_range);
  if (args.odom_xy_per_m) params->set_odom_xy_per_m(*args.odom_xy_per_m);
  if (args.odom_theta_per_rad) params->set_odom_theta_per_rad(*args.odom_theta_per_rad);
  if (args.odom_theta_per_m) params->set_odom_theta_per_m(*args.odom_theta_per_m);
  if (args.match_chi2) params->set_match_chi2(*args.match_chi2);
  if (args.localize) *config->mutable_localize() = *args.localize;
  return create;
}

int RunSlamReplay(CommandContext& context, const ReplayArgs& args, const StopRequested& stop) {
  auto opened = OpenFeed(args.log, args.restamp, args.rate_hz);
  if (!opened.ok()) return ReportError(context, opened.status());
  CarmenLaserFeed& feed = **opened;
  const SlamOutTarget target = SlamOutTargetOf(
      args.out_dir.empty() ? std::filesystem::path("out") / LogName(args.log)
                           : std::filesystem::path(args.out_dir));

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
  auto session = client->CreateSession(SessionRequest(args, record.laser));
  if (!session.ok()) return ReportError(context, session.status(), "CreateSession");
  ReplayReport report;
  report.log = args.log;
  report.allow_inconsistent_map = args.allow_inconsistent_map;
  report.session_id = session->session_id();
  report.realtime = args.realtime;
  if (args.restamp) report.restamp_rate_hz = args.rate_hz;

  Answers answers;
  std::unique_ptr<client::SensorStream> stream = client->StreamSensorData(
      report.session_id, args.window, [&answers](const v1::SlamUpdate& u) { answers.Add(u); });

  const bool by_scans = args.max_scans > 0;
  ReplayProgress progress(context, args);
  const double first_stamp = record.laser.stamp;
  std::vector<Vec2> odometry_path;
  const Clock::time_point start = Clock::now();
  absl::Status failure;
  report.end = ReplayEnd::kEndOfLog;
  for (bool more = true; more;) {
    if (args.realtime) {
      SleepUntil(start + std::chrono::duration_cast<Clock::duration>(
                             std::chrono::duration<double>(record.laser.stamp - first_stamp)),
                 stop);
    }
    if (stop && stop()) {
      report.end = ReplayEnd::kInterrupted;
      break;
    }
    const ReplayStep step = ReplayStepOf(record.laser);
    if (failure = stream->SendOdometry(step.odometry); failure.ok()) {
      failure = stream->SendScan(step.scan);
    }
    if (!failure.ok()) {
      report.end = ReplayEnd::kFailed;
      break;
    }
    report.span.Add(record.laser.stamp);
    if (args.show_odometry) {
      odometry_path.push_back({record.laser.odom_pose.x, record.laser.odom_pose.y});
    }
    const int64_t sent = report.span.scans();
    if (sent % 16 == 0) progress.Update(sent, stream->stats().updates);
    if (by_scans && sent >= args.max_scans) {
      report.end = ReplayEnd::kMaxScans;
      break;
    }
    auto next = feed.Next(&record);
    if (!next.ok()) {
      failure = absl::Status(next.status().code(),
                             absl::StrCat(next.status().message(), " (", args.log, ")"));
      report.end = ReplayEnd::kFailed;
      break;
    }
    more = *next;
  }
  // Half-closes and waits for the answers to everything sent, also after Ctrl-C.
  const absl::Status finished = stream->Finish();
  report.processing_s = SecondsSince(start);
  // A send fails when the stream broke; Finish says why.
  if (!finished.ok() && (failure.ok() || failure.code() == absl::StatusCode::kUnavailable)) {
    failure = absl::Status(finished.code(),
                           absl::StrCat(finished.message(), " (stream of session ",
                                        report.session_id, ")"));
    report.end = ReplayEnd::kFailed;
  }
  if (!failure.ok()) report.error = StatusText(failure);
  // The last draw waits for the count, unless the run was interrupted (Ctrl-C ends it at once).
  progress.Update(report.span.scans(), stream->stats().updates,
                  /*final=*/report.end != ReplayEnd::kInterrupted);
  progress.Finish();
  PrintReadProblems(context, feed.reader());
  for (const std::string& r : answers.rejections()) context.err << "warning: rejected " << r << "\n";

  const client::SensorStream::Stats stats = stream->stats();
  report.scans_sent = stats.scans_sent;
  report.scans_answered = stats.updates;
  report.rejected = stats.scans_rejected + stats.odometry_rejected;
  report.queue_full = stats.queue_full;
  report.window = stream->window();
  report.max_outstanding = stats.max_outstanding;
  report.skipped_motion = answers.skipped_motion();
  const std::vector<double> server_ms = answers.server_ms();
  report.server_ms_p50 = Percentile(server_ms, 50);
  report.server_ms_p99 = Percentile(server_ms, 99);
  report.laser_lines = feed.laser_lines();
  report.skipped_stamps = feed.skipped_stamps();
  report.stamps_broken = feed.StampsBroken();
  report.reordered_lines = feed.reordered_lines();
  report.malformed_lines = feed.reader().malformed_lines();
  report.odometry_lines = feed.odometry_lines();

  report.loop_closures = answers.loop_closures();
  if (args.localize) {
    report.localize_map = args.localize->map_session_id();
    report.localized_scans = answers.localized();
    report.localization_statuses = answers.localization_statuses();
    report.ambiguous_answers = answers.ambiguous();
    if (const std::optional<Answers::Fix> fix = answers.first_fix()) {
      report.first_fix_scan = fix->scan;
      report.first_fix_stamp = fix->stamp;
      report.first_fix_score = fix->score;
      report.first_fix_rival_ratio = fix->rival_ratio;
      report.first_fix_rival_distance = fix->rival_distance;
    }
  }

  SessionResults results = CloseAndCollect(*client, report.session_id, answers, report);
  if (args.localize) {
    CollectLocalizationMap(*client, report.localize_map, args.grid_resolution, results, report);
  } else if (target.is_folder()) {
    results.grid = CollectGrid(*client, report.session_id, args.grid_resolution, report);
  }
  WriteOutputs(target, results, odometry_path, report);

  if (context.globals.json) {
    PrintJson(context.out, ReplayJson(report));
  } else {
    context.out << ReplayText(report);
  }
  const std::string stamps_warning = BrokenStampsWarning(feed);
  context.err << stamps_warning;
  context.err << InconsistentMapWarning(report);
  if (report.end == ReplayEnd::kFailed) return ReportError(context, failure, "replay");
  if (!report.write_error.empty()) {
    return ReportError(context, absl::DataLossError(report.write_error), target.path.string());
  }
  if (report.end == ReplayEnd::kInterrupted) return kExitInterrupted;
  if (!stamps_warning.empty()) return kExitFailure;
  if (FinalMapContradictsItself(report) && !args.allow_inconsistent_map) {
    return kExitInconsistentMap;
  }
  return kExitOk;
}

int RunSlamOdometry(CommandContext& context, const OdometryArgs& args) {
  auto opened = OpenFeed(args.log, args.restamp, args.rate_hz);
  if (!opened.ok()) return ReportError(context, opened.status());
  CarmenLaserFeed& feed = **opened;
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
                            {"stamps_broken", feed.StampsBroken()},
                            {"stamps", feed.restamped() ? "synthesized" : "log"},
                            {"restamp_rate_hz", feed.restamped()
                                                    ? nlohmann::json(feed.restamp_rate_hz())
                                                    : nlohmann::json(nullptr)},
                            {"reordered_lines", feed.reordered_lines()},
                            {"malformed_lines", feed.reader().malformed_lines()}});
  } else {
    context.out << "wrote " << poses.size() << " odometry poses to " << args.out;
    if (feed.restamped()) {
      context.out << fmt::format(" (stamps synthesized from the line order at {:g} Hz)\n",
                                 feed.restamp_rate_hz());
    } else {
      context.out << " (" << feed.reordered_lines() << " laser lines reordered by stamp, "
                  << feed.skipped_stamps() << " with a repeated or out-of-order stamp skipped)\n";
    }
  }
  const std::string stamps_warning = BrokenStampsWarning(feed);
  context.err << stamps_warning;
  return stamps_warning.empty() ? kExitOk : kExitFailure;
}

}  // namespace waymark::cli
