#ifndef WAYMARK_CLIENT_SIM_SIM_ROBOT_H_
#define WAYMARK_CLIENT_SIM_SIM_ROBOT_H_

// A simulated Pioneer 3-DX with a SICK LMS200 in a World (sim_world.h). Time is simulated: it
// only moves when the loop calls Advance(), so a run is as fast as the computer and exactly
// repeatable for a given seed.
//
// - Base: unicycle kinematics integrated every `step` seconds, velocities clamped to the limits
//   (the paper's 0.15 m/s and 0.17 rad/s). The body is a disc; a step that would bring it within
//   `body_radius` of a wall is not taken (the robot stops there, bumped = true) and counts as one
//   collision (a contact that lasts several steps counts once).
// - Odometry: the true increment of each step distorted by a systematic error (scale of the
//   distance travelled, scale of the angle turned, heading drift per metre) and a random one
//   (Gaussian, standard deviation proportional to the distance and angle of the step), then
//   integrated: it drifts like a real base's.
// - Laser: ray casting against the walls from the laser's mount, beams over [-90, 90] degrees at
//   1 degree (181 beams) or 0.5 degree (361), Gaussian range noise, quantised to millimetres;
//   a beam that hits nothing within max_range reads no_return_range.

#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/devices/robot_devices.h"
#include "client/sim/sim_world.h"

namespace waymark::adapters {

struct OdometryError {
  double distance_scale = 1.01;     // systematic: odometry distance / true distance
  double turn_scale = 1.005;        // systematic: odometry angle / true angle
  double drift_per_m = 0.005;       // systematic: rad of heading error per metre driven
  double distance_sigma = 0.02;     // random: m per m travelled (1 sigma)
  double turn_sigma = 0.02;         // random: rad per rad turned
  double turn_per_m_sigma = 0.005;  // random: rad per m travelled
};

struct SimOptions {
  std::uint64_t seed = 1;
  double step = 0.01;          // integration step (s)
  double max_linear = 0.15;    // m/s
  double max_angular = 0.17;   // rad/s
  double body_radius = 0.25;   // m
  OdometryError odometry;
  // Laser.
  bool half_degree = false;    // 361 beams at 0.5 degree instead of 181 at 1 degree
  double max_range = 8.0;      // m
  double no_return_range = 8.183;  // what a beam without a return reads (LMS200: 8183 mm)
  double range_sigma = 0.01;   // m, 1 sigma
  BasePose laser_mount{0.16, 0.0, 0.0};  // laser on the robot (P3-DX front mount)
  // Where the robot starts; unset: the world's start (several robots in one world start apart).
  std::optional<BasePose> start;
};

// Another robot in the same world (several robots exploring together): a disc the laser sees and
// the base bumps into, like a wall.
struct OtherBody {
  double x = 0;
  double y = 0;
  double radius = 0.25;
};

// The simulation and its ground truth. Not thread-safe.
class Simulation {
 public:
  Simulation(World world, const SimOptions& options);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Moves time on by `seconds` (>= 0) under the current velocity command.
  void Advance(double seconds);

  double now() const { return time_; }
  const World& world() const { return world_; }
  const SimOptions& options() const { return options_; }
  BasePose true_pose() const { return pose_; }
  BasePose odometry_pose() const { return odometry_; }
  int collisions() const { return collisions_; }
  bool bumped() const { return bumped_; }
  double distance_travelled() const { return travelled_; }  // true path length, m

  // The devices, for a robot loop (they share this simulation; it must outlive them).
  MobileBase& base();
  LaserScanner& laser();

  // The other robots as they stand now (replaced at each call; none by default).
  void SetOtherBodies(std::vector<OtherBody> bodies) { others_ = std::move(bodies); }

  // One scan from the current true pose (what laser().Read() returns).
  LaserReading Scan();
  LaserLayout laser_layout() const;

 private:
  class Base;
  class Laser;
  void Step(double dt);
  // Distance from (x, y) to the nearest wall or other robot's body.
  double ClearanceAt(double x, double y) const;

  World world_;
  SimOptions options_;
  std::mt19937_64 rng_;
  double time_ = 0;
  BasePose pose_;
  BasePose odometry_;
  double cmd_linear_ = 0;
  double cmd_angular_ = 0;
  double linear_ = 0;
  double angular_ = 0;
  int collisions_ = 0;
  bool bumped_ = false;
  double travelled_ = 0;
  std::vector<OtherBody> others_;
  std::unique_ptr<Base> base_;
  std::unique_ptr<Laser> laser_;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_SIM_SIM_ROBOT_H_
