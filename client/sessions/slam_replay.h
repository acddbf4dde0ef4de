#ifndef WAYMARK_CLIENT_SESSIONS_SLAM_REPLAY_H_
#define WAYMARK_CLIENT_SESSIONS_SLAM_REPLAY_H_

// `waymark slam replay LOG` and `waymark slam odometry LOG`: CARMEN logs into a SLAM session.
//
// What is sent, per laser line (FLASER or ROBOTLASER1), in file order:
//   1. an Odometry message with the odometry pose embedded in the laser line (FLASER odom_x/y/theta,
//      ROBOTLASER1 robot_x/y/theta) at the laser line's stamp, then
//   2. the scan, with its own beam geometry.
// ODOM lines are read but not sent: every laser line carries the odometry at its own instant, which
// is exactly what the EKF's prediction needs, and the raw logs' ODOM lines add nothing between two
// scans that the next scan's pose does not. Laser lines are sent in stamp order: the reader looks
// 64 laser lines ahead and reorders (in the Intel log 631 FLASER lines carry a smaller stamp than
// the line before them, none is repeated, none is more than 14 lines out of place;
// reordered_lines counts the lines whose stamp is below one read earlier: 1612 there). A line whose stamp still does not increase (a duplicate,
// or out of order by more than the lookahead) is skipped and counted (skipped_stamps), since the
// server would reject it. Malformed lines are skipped and counted (the first few are printed).
//
// The session's laser pose on the robot is inv(odom pose) (+) laser pose of the first laser line
// when that offset is plausible (under 1 m and 0.1 rad); otherwise (e.g. GMapping-corrected logs,
// whose laser pose is the corrected pose) the laser is assumed at the robot's origin.

#include <optional>
#include <string>

#include "client/common/command_context.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::adapters {
struct CarmenLaser;
}  // namespace waymark::adapters

namespace waymark::cli {

struct ReplayArgs {
  std::string log;
  std::string out_dir;  // default ./out/<log name>
  std::string robot_id = "replay";
  std::string name;
  bool realtime = false;
  int max_scans = 0;  // 0 = all
  int window = client::kDefaultScanWindow;
  bool show_odometry = false;
  // LaserSlamParams; unset = server default.
  std::optional<double> max_range;
  std::optional<double> odom_xy_per_m;
  std::optional<double> odom_theta_per_rad;
  std::optional<double> odom_theta_per_m;
  std::optional<double> match_chi2;
};

int RunSlamReplay(CommandContext& context, const ReplayArgs& args);

struct OdometryArgs {
  std::string log;
  std::string out;  // TUM file
  int max_scans = 0;
};

int RunSlamOdometry(CommandContext& context, const OdometryArgs& args);

// The laser's pose on the robot from one laser line: inv(odom pose) (+) laser pose when under 1 m
// and 0.1 rad, else the robot's origin (see the file comment). Shared with bench/laser_slam_eval.
Pose2 LaserMount(const adapters::CarmenLaser& laser);

// "aces" for ".../aces.clf.bz2", "intel-corrected" for "intel-corrected.log.gz".
std::string LogName(const std::string& path);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_SLAM_REPLAY_H_
