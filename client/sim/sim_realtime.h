#ifndef WAYMARK_CLIENT_SIM_SIM_REALTIME_H_
#define WAYMARK_CLIENT_SIM_SIM_REALTIME_H_

// The simulator (sim_robot.h) running against the wall clock, so `waymark robot --base sim:WORLD`
// behaves like a robot on serial cables: the laser delivers a scan every `scan_period` simulated
// seconds and Read() blocks until it is due, the base keeps moving between calls, and several
// threads may use the devices (the robot loop and its safety watchdog do). `speed` runs the world
// faster than real time (tests use 10-50x); stamps are simulated seconds.

#include <functional>
#include <memory>
#include <mutex>

#include "absl/status/statusor.h"
#include "client/devices/robot_devices.h"
#include "client/sim/sim_robot.h"

namespace waymark::adapters {

struct RealTimeSimOptions {
  SimOptions sim;
  double speed = 1.0;        // simulated seconds per wall-clock second (> 0)
  double scan_period = 0.1;  // simulated seconds between scans (LMS200 at 38400 baud: ~10 Hz)
};

class RealTimeSimulation {
 public:
  // Wall-clock seconds; injectable for tests. The default is a steady clock.
  using Clock = std::function<double()>;
  RealTimeSimulation(World world, const RealTimeSimOptions& options, Clock clock = {});
  ~RealTimeSimulation();

  MobileBase& base();
  LaserScanner& laser();

  // Ground truth for summaries, at the current simulated time.
  BasePose true_pose();
  int collisions();
  double distance_travelled();
  double now();  // simulated seconds
  const RealTimeSimOptions& options() const { return options_; }

 private:
  class Base;
  class Laser;
  // Advances the simulation to the wall clock's time. Call with mutex_ held.
  void CatchUpLocked();
  // Runs `f` on the simulation caught up with the wall clock, under the lock.
  template <typename F>
  auto CaughtUp(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    CatchUpLocked();
    return f(sim_);
  }
  double SimTimeNow() const;

  RealTimeSimOptions options_;
  Clock clock_;
  double wall_start_ = 0;
  std::mutex mutex_;
  Simulation sim_;
  double next_scan_ = 0;  // simulated time of the next scan
  std::unique_ptr<Base> base_;
  std::unique_ptr<Laser> laser_;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_SIM_SIM_REALTIME_H_
