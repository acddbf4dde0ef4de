#ifndef WAYMARK_TESTS_LASER_SLAM_ENGINE_LOOP_H_
#define WAYMARK_TESTS_LASER_SLAM_ENGINE_LOOP_H_

// A closed loop robot <-> laser SLAM session, in process, for the exploration tests: a world of
// walls, a ray-casting laser (synthetic_scan.h), perfect odometry and a noise-free laser. The
// robot executes each suggestion exactly (go-stop), then scans.

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/options.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam::testing {

// The wall from (x1, y1) to (x2, y2).
Wall W(double x1, double y1, double x2, double y2);

// Distance from `p` to the nearest wall (infinity without walls).
double DistanceToWalls(const std::vector<Wall>& walls, const Eigen::Vector2d& p);

class EngineLoop {
 public:
  EngineLoop(std::vector<Wall> walls, const Pose2& start, const SlamOptions& options);

  // One scan from where the robot stands (1-degree LMS200, no noise) into the session.
  ScanUpdate Observe();

  // Moves along the suggested arc in 0.1 s steps, feeding odometry; returns the smallest
  // distance from the robot's centre to a wall along the way.
  double Apply(const Suggestion& s);

  const Pose2& truth() const { return truth_; }
  LaserSlam& slam() { return slam_; }

 private:
  std::vector<Wall> walls_;
  Pose2 truth_;
  Pose2 start_;
  LaserSlam slam_;
  double t_ = 0.0;
};

}  // namespace waymark::laser_slam::testing

#endif  // WAYMARK_TESTS_LASER_SLAM_ENGINE_LOOP_H_
