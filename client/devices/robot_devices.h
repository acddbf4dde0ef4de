#ifndef WAYMARK_CLIENT_DEVICES_ROBOT_DEVICES_H_
#define WAYMARK_CLIENT_DEVICES_ROBOT_DEVICES_H_

// The two devices a robot loop talks to: a mobile base (wheel odometry in, velocity commands out)
// and a 2-D laser scanner. The simulator (sim_robot.h) and the serial adapters for the Pioneer
// (ARCOS/P2OS) and the SICK LMS200 implement the same interfaces, so one loop drives either.
//
// Units are SI: metres, radians, seconds. Stamps are seconds on the device's clock (the simulated
// clock for the simulator, the host's clock for serial devices); a loop only needs them to increase.

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::adapters {

struct BasePose {
  double x = 0;
  double y = 0;
  double theta = 0;
};

// One odometry report of the base.
struct BaseState {
  double stamp = 0;
  BasePose odometry;      // cumulative wheel-odometry pose in the odometry frame
  double linear = 0;      // measured velocities (m/s, rad/s)
  double angular = 0;
  bool bumped = false;    // a bumper is pressed / the simulated body touches a wall
  bool stalled = false;   // a wheel is stalled
  bool motors_enabled = true;
  double battery_volts = 0;  // 0 when the base does not report it
};

class MobileBase {
 public:
  virtual ~MobileBase() = default;
  // Commands velocities; the base clamps them to its limits and holds them until the next command
  // (a real base's watchdog stops it when commands stop arriving).
  virtual absl::Status SetVelocity(double linear, double angular) = 0;
  virtual absl::Status Stop() = 0;
  // The latest odometry report.
  virtual absl::StatusOr<BaseState> Read() = 0;
  virtual double max_linear() const = 0;   // m/s
  virtual double max_angular() const = 0;  // rad/s
};

// Beam layout of a laser, as SlamService's LaserGeometry wants it.
struct LaserLayout {
  double angle_min = 0;        // bearing of the first beam in the laser frame (rad)
  double angle_increment = 0;  // rad
  std::uint32_t beam_count = 0;
  double no_return_range = 0;  // readings at or above are no-returns
  BasePose mount;              // laser pose on the robot
};

struct LaserReading {
  double stamp = 0;
  std::vector<float> ranges;  // one per beam, metres
};

class LaserScanner {
 public:
  virtual ~LaserScanner() = default;
  virtual LaserLayout layout() const = 0;
  // The next complete scan.
  virtual absl::StatusOr<LaserReading> Read() = 0;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_ROBOT_DEVICES_H_
