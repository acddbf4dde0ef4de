#ifndef WAYMARK_CLIENT_SESSIONS_SLAM_REPLAY_H_
#define WAYMARK_CLIENT_SESSIONS_SLAM_REPLAY_H_

// `waymark slam replay LOG` and `waymark slam odometry LOG`: CARMEN logs, or ROS bags (ROS 1 .bag,
// rosbag2 folders and .db3, MCAP), into a SLAM session. Both are read through one LaserSource
// (client/datasets/laser_source.h): CarmenLaserSource (carmen_laser_source.h) or, when the path
// is a bag (a folder, or a file starting like one), BagLaserFeed (client/ros/bag_laser_feed.h:
// the LaserScan topic, odometry from an Odometry topic or TF at each scan's header stamp, the
// laser's mounting from TF; --scan-topic and --odom-topic choose when the bag has several). The
// rest of this comment says what happens with a CARMEN log; a bag's scans go the same way.
//
// What is sent, per laser line (FLASER or ROBOTLASER1) in stamp order (CarmenLaserFeed: reordered
// within a lookahead, lines whose stamp does not increase skipped; or, with --restamp, in file
// order with stamps synthesized from the line number and a rate):
//   1. an Odometry message with the odometry pose embedded in the laser line (FLASER
//   odom_x/y/theta,
//      ROBOTLASER1 robot_x/y/theta) at the laser line's stamp, then
//   2. the scan, with its own beam geometry.
// ODOM lines are read but not sent: every laser line carries the odometry at its own instant, which
// is exactly what the EKF's prediction needs, and the raw logs' ODOM lines add nothing between two
// scans that the next scan's pose does not. Malformed lines are skipped and counted (the first few
// are printed).
//
// When most laser lines were skipped for their stamps, the replay still writes what it got but
// warns and exits 1, pointing at --restamp. Ctrl-C (a stop request) or an error mid-log ends the
// replay early: it says what was sent and answered, closes the session (or names it as left open
// and how to close it), and writes the outputs it can, marked partial in summary.json; the
// trajectory then comes from the stream's answers and the pictures have no map if the server
// cannot be asked. Exit codes: 0 done, 1 error or broken stamps, 3 the final map contradicts
// itself, 130 interrupted.
//
// The session's laser pose on the robot is inv(odom pose) (+) laser pose of the first laser line
// when that offset is plausible (under 1 m and 0.1 rad); otherwise (e.g. GMapping-corrected logs,
// whose laser pose is the corrected pose) the laser is assumed at the robot's origin.
//
// After the session is closed, its occupancy grid is fetched and written as map.pgm, map.yaml and
// occupancy.png into a folder --out; a session without a grid (loop closure off, a server older
// than GetOccupancyGrid) or any failure there is a note in the summary, never a failed replay.
// The closed session's map carries its self-check (GetMap; docs/laser-slam.md, "A map that checks
// itself"): printed, written to summary.json ("self_check") and drawn on occupancy.png. When the
// final map contradicts itself (a replay to the end of the log or --max-scans, session closed)
// the replay warns and exits 3 (kExitInconsistentMap) after writing everything, unless
// allow_inconsistent_map; intermediate maps are not judged (a map contradicts itself between
// re-entering a place and the closure that ties it).
// With `localize` set the session localizes on a stored map instead of mapping; the summary then
// counts the scans answered localized and names the first (the time to the first fix).

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "client/common/command_context.h"
#include "client/datasets/carmen_laser_feed.h"
#include "client/datasets/laser_source.h"
#include "client/datasets/tum_trajectory.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {


// A stretch of a recording's scans: FIRST:LAST is scans first .. last-1 (0-based); "FIRST:" runs to
// the end (last unset).
struct ScanSlice {
  int64_t first = 0;
  std::optional<int64_t> last;
};
// "FIRST:LAST" or "FIRST:"; INVALID_ARGUMENT naming what is wrong (not numbers, negative, LAST not
// above FIRST).
absl::StatusOr<ScanSlice> ParseScanSlice(const std::string& text);
// The source's scans in `slice` only (those before are read and dropped).
std::unique_ptr<adapters::LaserSource> SliceLaserSource(
    std::unique_ptr<adapters::LaserSource> source, const ScanSlice& slice);

// Asked before each scan is sent: true ends the replay early (Ctrl-C). Empty: never.
using StopRequested = std::function<bool()>;

struct ReplayArgs {
  std::string log;  // a CARMEN log or a bag
  std::string scan_topic;  // bags: --scan-topic (empty: the only LaserScan topic)
  std::string odom_topic;  // bags: --odom-topic (empty: automatic; "tf"; "none")
  std::string out_dir;  // default ./out/<log name>; a .svg or .png path: only that picture
  bool restamp = false;  // stamps from the line order at rate_hz
  double rate_hz = adapters::kDefaultRestampRateHz;
  // CARMEN logs: each scan with the odometry the log gives the scan this many lines later;
  // unset: estimated from the log (client/datasets/odometry_lag.h).
  std::optional<int> odometry_lag;
  std::string robot_id = "replay";
  std::string name;
  bool realtime = false;
  // At the log's pace times this (> 0; --speed): 20 sends 20 s of the log a second. 0: as
  // `realtime` says.
  double speed = 0.0;
  int max_scans = 0;  // 0 = all
  int window = client::kDefaultScanWindow;
  bool show_odometry = false;
  // LaserSlamParams; unset = server default.
  std::optional<double> max_range;
  std::optional<double> odom_xy_per_m;
  std::optional<double> odom_theta_per_rad;
  std::optional<double> odom_theta_per_m;
  std::optional<double> match_chi2;
  // GetOccupancyGrid's resolution (m per cell); unset = the server's default.
  std::optional<double> grid_resolution;
  // A final map that contradicts itself (its self-check) is warned about but exits 0, not 3.
  bool allow_inconsistent_map = false;
  // Set: a localization session on this map (LaserSlamConfig.localize) instead of a mapping one.
  std::optional<v1::LocalizationConfig> localize;
  // --map NAME: the session joins this shared map (CreateSessionRequest.map); the summary says
  // whether its trajectory is in the map. Empty = none.
  std::string map;
  // --scans FIRST:LAST: only the recording's scans FIRST .. LAST-1 (0-based, in the order the
  // source gives them), as one robot driving that stretch; unset = all. --max-scans still counts
  // the scans sent.
  std::optional<ScanSlice> scans;
  // --initial-pose X,Y,THETA with --map: where the robot starts in the map frame
  // (CreateSessionRequest.initial_map_pose); unset = found by the server.
  std::optional<v1::Pose2D> initial_map_pose;
};

// One laser line as a replay sends it: the odometry pose at its stamp, then the scan.
struct ReplayStep {
  v1::Odometry odometry;
  v1::LaserScan scan;
};
ReplayStep ReplayStepOf(const adapters::LaserSample& sample);
ReplayStep ReplayStepOf(const adapters::CarmenLaser& laser);
v1::LaserGeometry GeometryOf(const adapters::LaserSample& sample);
// The CreateSession a replay sends for a recording whose first scan is `first`, the laser mounted
// at `mount` on the robot.
v1::CreateSessionRequest SessionRequest(const ReplayArgs& args, const adapters::LaserSample& first,
                                        const Pose2& mount);
// The same for a log whose first laser line is `first` (its mounting from LaserMount).
v1::CreateSessionRequest SessionRequest(const ReplayArgs& args, const adapters::CarmenLaser& first);

// A recording opened for a replay: the source, and how to count its scans on the side (for the
// progress bar; gives up, returning 0, once the flag is set).
struct OpenedLaserSource {
  std::unique_ptr<adapters::LaserSource> source;
  std::function<int64_t(const std::atomic<bool>* cancel)> count_scans;
};
// A bag (ros::LooksLikeBag: a rosbag2 folder, or a file whose first bytes are a ROS 1 bag's, an
// MCAP's or SQLite's) is read with the topic flags; anything else as a CARMEN log (restamped at rate_hz when restamp). A bag
// with --restamp is refused (its header stamps are what it is read by). A CARMEN log's scans take
// the odometry the log gives the scan odometry_lag lines later (nullopt: estimated from the log,
// CarmenLaserSource::Open); a bag with a lag other than 0 is refused (its odometry is placed by
// stamps, not lines).
absl::StatusOr<OpenedLaserSource> OpenLaserSource(const std::string& path, bool restamp,
                                                  double rate_hz, const std::string& scan_topic,
                                                  const std::string& odom_topic,
                                                  std::optional<int> odometry_lag = 0);

int RunSlamReplay(CommandContext& context, const ReplayArgs& args,
                  const StopRequested& stop = {});

struct OdometryArgs {
  std::string log;
  std::string scan_topic;  // bags, as in ReplayArgs
  std::string odom_topic;
  std::string out;  // TUM file
  int max_scans = 0;
  bool restamp = false;
  double rate_hz = adapters::kDefaultRestampRateHz;
};

int RunSlamOdometry(CommandContext& context, const OdometryArgs& args);

// The laser's pose on the robot from one laser line: inv(odom pose) (+) laser pose when under 1 m
// and 0.1 rad, else the robot's origin (see the file comment). Shared with
// bench/laser/laser_slam_eval.
Pose2 LaserMount(const adapters::CarmenLaser& laser);

// "aces" for ".../aces.clf.bz2", "intel-corrected" for "intel-corrected.log.gz".
std::string LogName(const std::string& path);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_SLAM_REPLAY_H_
