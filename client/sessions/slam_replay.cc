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

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/bags/bag_reader.h"
#include "client/datasets/carmen_log.h"
#include "client/datasets/tum_trajectory.h"
#include "client/eval/eval_metrics.h"      // Percentile
#include "client/eval/relations_metric.h"  // Compose, Inverse
#include "client/render/occupancy_picture.h"
#include "client/render/slam_output.h"
#include "client/robot/laser_session.h"
#include "client/ros/bag_laser_feed.h"
#include "client/ros/bag_path.h"
#include "client/sessions/carmen_laser_source.h"
#include "client/sessions/replay_report.h"
#include "client/sessions/session_grid.h"

namespace waymark::cli {
namespace {

using adapters::CarmenLaser;
using adapters::CarmenLaserFeed;
using adapters::CarmenRecord;
using adapters::LaserSample;
using adapters::LaserSource;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string StatusText(const absl::Status& status) {
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message());
}

void PrintReadProblems(CommandContext& context, const LaserSource& source) {
  for (const std::string& warning : source.Warnings()) {
    context.err << "warning: " << warning << "\n";
  }
}

// What a bag's index says its scan topic holds (0 when it cannot say).
int64_t CountBagScans(const std::string& path, const std::string& scan_topic) {
  auto reader = bags::OpenBag(path);
  if (!reader.ok()) return 0;
  auto summary = (*reader)->Summary();
  if (!summary.ok()) return 0;
  for (const bags::BagTopicSummary& topic : summary->topics) {
    if (topic.topic == scan_topic) return topic.messages;
  }
  return 0;
}

// The laser scans a replay of a CARMEN `log` sends when it is not stopped: the log read through a
// source of its own with the same options, so scans skipped for their stamps are not counted. For
// the progress bar, which follows the scans sent (the reader itself reads ahead of what was sent:
// a compressed log can be read whole while the first scans go out). 0 when the log cannot be read.
// Gives up (0) once `cancel` is set.
int64_t CountLogScans(const std::string& log, double restamp_rate_hz,
                      const std::atomic<bool>* cancel) {
  auto source = CarmenLaserSource::Open(log, restamp_rate_hz);
  if (!source.ok()) return 0;
  LaserSample sample;
  int64_t scans = 0;
  while (!cancel->load()) {
    auto next = (*source)->Next(&sample);
    if (!next.ok() || !*next) break;
    ++scans;
  }
  return scans;
}

// The replay's progress bar: scans sent of the scans in the log (or of --max-scans), drawn once
// the log has been counted on a thread of its own (a bar with a total, never one of bytes read).
class ReplayProgress {
 public:
  ReplayProgress(CommandContext& context, const ReplayArgs& args,
                 const std::function<int64_t(const std::atomic<bool>*)>& count_scans)
      : context_(context), max_scans_(args.max_scans) {
    if (!context.err_is_tty || !count_scans) return;  // the bar is for a person watching
    total_ = std::async(std::launch::async, count_scans, &cancel_);
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
  report.graph_nodes = results.map.graph_nodes();
  report.pruned_nodes = results.map.pruned_nodes();
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

v1::LaserGeometry GeometryOf(const LaserSample& sample) {
  v1::LaserGeometry geometry;
  geometry.set_angle_min(sample.angle_min);
  geometry.set_angle_increment(sample.angle_increment);
  geometry.set_beam_count(static_cast<uint32_t>(sample.ranges.size()));
  geometry.set_no_return_range(sample.no_return_range);
  return geometry;
}

ReplayStep ReplayStepOf(const LaserSample& sample) {
  ReplayStep step;
  step.odometry.set_stamp(sample.stamp);
  *step.odometry.mutable_pose() = ToProto(sample.odom);
  step.scan.set_stamp(sample.stamp);
  *step.scan.mutable_geometry() = GeometryOf(sample);
  step.scan.mutable_ranges()->Assign(sample.ranges.begin(), sample.ranges.end());
  return step;
}

ReplayStep ReplayStepOf(const CarmenLaser& laser) { return ReplayStepOf(SampleOf(laser)); }

v1::CreateSessionRequest SessionRequest(const ReplayArgs& args, const LaserSample& first,
                                        const Pose2& mount) {
  v1::CreateSessionRequest create;
  create.set_robot_id(args.robot_id);
  create.set_name(args.name.empty() ? "replay of " + LogName(args.log) : args.name);
  v1::LaserSlamConfig* config = create.mutable_laser();
  *config->mutable_laser() = GeometryOf(first);
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
  create.set_map(args.map);
  if (args.initial_map_pose) *create.mutable_initial_map_pose() = *args.initial_map_pose;
  return create;
}

v1::CreateSessionRequest SessionRequest(const ReplayArgs& args, const CarmenLaser& first) {
  return SessionRequest(args, SampleOf(first), LaserMount(first));
}

absl::StatusOr<ScanSlice> ParseScanSlice(const std::string& text) {
  const size_t colon = text.find(':');
  const auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(
        absl::StrCat("--scans \"", text, "\": ", why, " (FIRST:LAST, scans FIRST to LAST-1 "
                     "counted from 0; FIRST: to the end)"));
  };
  if (colon == std::string::npos) return bad("no ':'");
  ScanSlice slice;
  if (!absl::SimpleAtoi(text.substr(0, colon), &slice.first)) return bad("FIRST is not a number");
  if (slice.first < 0) return bad("FIRST is negative");
  const std::string last = text.substr(colon + 1);
  if (!last.empty()) {
    int64_t value = 0;
    if (!absl::SimpleAtoi(last, &value)) return bad("LAST is not a number");
    if (value <= slice.first) return bad("LAST must be above FIRST");
    slice.last = value;
  }
  return slice;
}

namespace {

// SliceLaserSource's source: skips the first scans, ends after the last.
class SlicedSource final : public LaserSource {
 public:
  SlicedSource(std::unique_ptr<LaserSource> source, const ScanSlice& slice)
      : source_(std::move(source)), slice_(slice) {}

  absl::StatusOr<bool> Next(LaserSample* sample) override {
    while (next_ < slice_.first) {
      absl::StatusOr<bool> more = source_->Next(sample);
      if (!more.ok() || !*more) return more;
      ++next_;
    }
    if (slice_.last.has_value() && next_ >= *slice_.last) return false;
    absl::StatusOr<bool> more = source_->Next(sample);
    if (more.ok() && *more) ++next_;
    return more;
  }
  Pose2 LaserMount() const override { return source_->LaserMount(); }
  adapters::LaserSourceCounts counts() const override { return source_->counts(); }
  std::vector<std::string> Warnings() const override { return source_->Warnings(); }
  std::string BrokenStampsWarning() const override { return source_->BrokenStampsWarning(); }
  std::vector<std::pair<std::string, std::string>> Facts() const override {
    return source_->Facts();
  }

 private:
  std::unique_ptr<LaserSource> source_;
  const ScanSlice slice_;
  int64_t next_ = 0;  // index of the next scan the source gives
};

}  // namespace

std::unique_ptr<LaserSource> SliceLaserSource(std::unique_ptr<LaserSource> source,
                                              const ScanSlice& slice) {
  return std::make_unique<SlicedSource>(std::move(source), slice);
}

absl::StatusOr<OpenedLaserSource> OpenLaserSource(const std::string& path, bool restamp,
                                                  double rate_hz, const std::string& scan_topic,
                                                  const std::string& odom_topic,
                                                  std::optional<int> odometry_lag) {
  OpenedLaserSource opened;
  if (ros::LooksLikeBag(path)) {
    if (odometry_lag && *odometry_lag != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          path, " is a bag: --odometry-lag is for CARMEN logs (a bag's odometry is placed by its "
                "stamps)"));
    }
    if (restamp) {
      return absl::InvalidArgumentError(absl::StrCat(
          path, " is a bag: --restamp is for CARMEN logs (a bag's scans are placed by their "
                "header stamps)"));
    }
    auto reader = bags::OpenBag(path);
    if (!reader.ok()) return reader.status();
    ros::BagLaserOptions options;
    options.scan_topic = scan_topic;
    options.odom_topic = odom_topic;
    auto summary_format = (*reader)->Summary();
    if (summary_format.ok()) options.format = summary_format->format;
    auto feed = ros::BagLaserFeed::Create(*std::move(reader), options);
    if (!feed.ok()) {
      return absl::Status(feed.status().code(),
                          absl::StrCat(path, ": ", feed.status().message()));
    }
    const std::string topic = (*feed)->topics().scan_topic;
    opened.count_scans = [path, topic](const std::atomic<bool>*) {
      return CountBagScans(path, topic);
    };
    opened.source = *std::move(feed);
    return opened;
  }
  if (!scan_topic.empty() || !odom_topic.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, " is not a bag (a ROS 1 .bag, an .mcap, a rosbag2 folder or .db3): --scan-topic "
              "and --odom-topic choose a bag's topics"));
  }
  const double restamp_rate = restamp ? rate_hz : 0;
  auto source = CarmenLaserSource::Open(path, restamp_rate, odometry_lag);
  if (!source.ok()) return source.status();
  opened.source = *std::move(source);
  opened.count_scans = [path, restamp_rate](const std::atomic<bool>* cancel) {
    return CountLogScans(path, restamp_rate, cancel);
  };
  return opened;
}

int RunSlamReplay(CommandContext& context, const ReplayArgs& args, const StopRequested& stop) {
  auto opened = OpenLaserSource(args.log, args.restamp, args.rate_hz, args.scan_topic,
                                args.odom_topic, args.odometry_lag);
  if (!opened.ok()) return ReportError(context, opened.status());
  if (args.scans.has_value()) {
    opened->source = SliceLaserSource(std::move(opened->source), *args.scans);
    opened->count_scans = [count = std::move(opened->count_scans),
                           slice = *args.scans](const std::atomic<bool>* cancel) -> int64_t {
      int64_t total = count(cancel);
      if (slice.last.has_value()) total = std::min(total, *slice.last);
      return std::max<int64_t>(0, total - slice.first);
    };
  }
  LaserSource& source = *opened->source;
  const SlamOutTarget target = SlamOutTargetOf(
      args.out_dir.empty() ? std::filesystem::path("out") / LogName(args.log)
                           : std::filesystem::path(args.out_dir));

  LaserSample sample;
  auto first = source.Next(&sample);
  if (!first.ok()) return ReportError(context, first.status(), args.log);
  if (!*first) {
    PrintReadProblems(context, source);
    return ReportError(context,
                       absl::InvalidArgumentError(
                           source.Facts().empty()
                               ? "the log has no laser lines (FLASER or ROBOTLASER1)"
                               : "the bag has no usable scans (see the warnings above)"),
                       args.log);
  }

  std::unique_ptr<client::SlamClient> client = context.ConnectSlam();
  auto session = client->CreateSession(SessionRequest(args, sample, source.LaserMount()));
  if (!session.ok()) return ReportError(context, session.status(), "CreateSession");
  ReplayReport report;
  report.log = args.log;
  report.allow_inconsistent_map = args.allow_inconsistent_map;
  report.session_id = session->session_id();
  report.realtime = args.realtime;
  if (args.restamp) report.restamp_rate_hz = args.rate_hz;

  if (args.scans.has_value()) {
    report.scan_slice =
        absl::StrCat(args.scans->first, ":", args.scans->last ? absl::StrCat(*args.scans->last) : "");
  }

  Answers answers;
  std::atomic<uint64_t> map_pose_answers{0};
  std::atomic<uint64_t> map_pose_tied{0};
  std::unique_ptr<client::SensorStream> stream = client->StreamSensorData(
      report.session_id, args.window, [&](const v1::SlamUpdate& u) {
        answers.Add(u);
        if (u.has_map_pose()) {
          ++map_pose_answers;
          if (u.map_pose().tied_in()) ++map_pose_tied;
        }
      });

  const bool by_scans = args.max_scans > 0;
  ReplayProgress progress(context, args, opened->count_scans);
  const double first_stamp = sample.stamp;
  std::vector<Vec2> odometry_path;
  const Clock::time_point start = Clock::now();
  absl::Status failure;
  report.end = ReplayEnd::kEndOfLog;
  for (bool more = true; more;) {
    if (args.realtime || args.speed > 0.0) {
      const double pace = args.speed > 0.0 ? args.speed : 1.0;
      SleepUntil(start + std::chrono::duration_cast<Clock::duration>(
                             std::chrono::duration<double>((sample.stamp - first_stamp) / pace)),
                 stop);
    }
    if (stop && stop()) {
      report.end = ReplayEnd::kInterrupted;
      break;
    }
    const ReplayStep step = ReplayStepOf(sample);
    if (failure = stream->SendOdometry(step.odometry); failure.ok()) {
      failure = stream->SendScan(step.scan);
    }
    if (!failure.ok()) {
      report.end = ReplayEnd::kFailed;
      break;
    }
    report.span.Add(sample.stamp);
    if (args.show_odometry) {
      odometry_path.push_back({sample.odom.x, sample.odom.y});
    }
    const int64_t sent = report.span.scans();
    if (sent % 16 == 0) progress.Update(sent, stream->stats().updates);
    if (by_scans && sent >= args.max_scans) {
      report.end = ReplayEnd::kMaxScans;
      break;
    }
    auto next = source.Next(&sample);
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
  PrintReadProblems(context, source);
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
  const adapters::LaserSourceCounts counts = source.counts();
  report.laser_lines = counts.laser_lines;
  report.skipped_stamps = counts.skipped_stamps;
  report.stamps_broken = counts.stamps_broken;
  report.reordered_lines = counts.reordered_lines;
  report.malformed_lines = counts.malformed_lines;
  report.odometry_lines = counts.odometry_lines;
  report.odometry_lag_scans = counts.odometry_lag_scans;
  report.source_facts = source.Facts();

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
  if (!args.map.empty()) {
    report.shared_map = args.map;
    report.map_pose_answers = map_pose_answers;
    report.map_pose_tied = map_pose_tied;
    if (absl::StatusOr<v1::Map> map = client->GetMapInfo(args.map); map.ok()) {
      report.shared_map_revision = map->revision();
      report.shared_map_trajectories = map->trajectories_size();
      for (int i = 0; i < map->trajectories_size(); ++i) {
        if (map->trajectories(i).session_id() != report.session_id) continue;
        report.shared_map_trajectory = i + 1;
        report.shared_map_tied_in = map->trajectories(i).tied_in();
      }
      if (report.shared_map_trajectory == 0) {
        report.shared_map_note = "the session is no longer in the map (the map was replaced)";
      }
    } else {
      report.shared_map_note = "could not read the map: GetMapInfo: " + StatusText(map.status());
    }
  }
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
  const std::string stamps_warning = source.BrokenStampsWarning();
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
  auto opened =
      OpenLaserSource(args.log, args.restamp, args.rate_hz, args.scan_topic, args.odom_topic);
  if (!opened.ok()) return ReportError(context, opened.status());
  LaserSource& source = *opened->source;
  std::vector<StampedPose> poses;
  LaserSample sample;
  while (args.max_scans <= 0 || static_cast<int>(poses.size()) < args.max_scans) {
    auto more = source.Next(&sample);
    if (!more.ok()) return ReportError(context, more.status(), args.log);
    if (!*more) break;
    poses.push_back({sample.stamp, sample.odom});
  }
  PrintReadProblems(context, source);
  if (absl::Status s = WriteTumFile(args.out, poses); !s.ok()) return ReportError(context, s);
  const adapters::LaserSourceCounts counts = source.counts();
  if (context.globals.json) {
    nlohmann::json json = {{"log", args.log},
                           {"out", args.out},
                           {"poses", poses.size()},
                           {"skipped_stamps", counts.skipped_stamps},
                           {"stamps_broken", counts.stamps_broken},
                           {"stamps", args.restamp ? "synthesized" : "log"},
                           {"restamp_rate_hz", args.restamp ? nlohmann::json(args.rate_hz)
                                                            : nlohmann::json(nullptr)},
                           {"reordered_lines", counts.reordered_lines},
                           {"malformed_lines", counts.malformed_lines}};
    const auto facts = source.Facts();
    if (!facts.empty()) {
      nlohmann::json bag = nlohmann::json::object();
      for (const auto& [key, value] : facts) bag[key] = value;
      json["bag"] = bag;
    }
    PrintJson(context.out, json);
  } else {
    context.out << "wrote " << poses.size() << " odometry poses to " << args.out;
    if (args.restamp) {
      context.out << fmt::format(" (stamps synthesized from the line order at {:g} Hz)\n",
                                 args.rate_hz);
    } else {
      context.out << " (" << counts.reordered_lines << " laser lines reordered by stamp, "
                  << counts.skipped_stamps << " with a repeated or out-of-order stamp skipped)\n";
    }
  }
  const std::string stamps_warning = source.BrokenStampsWarning();
  context.err << stamps_warning;
  return stamps_warning.empty() ? kExitOk : kExitFailure;
}

}  // namespace waymark::cli
