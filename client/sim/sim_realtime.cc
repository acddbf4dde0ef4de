#include "client/sim/sim_realtime.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "client/common/steady_clock.h"

namespace waymark::adapters {

class RealTimeSimulation::Base final : public MobileBase {
 public:
  explicit Base(RealTimeSimulation& owner) : owner_(owner) {}
  absl::Status SetVelocity(double linear, double angular) override {
    return owner_.CaughtUp(
        [&](Simulation& sim) { return sim.base().SetVelocity(linear, angular); });
  }
  absl::Status Stop() override {
    return owner_.CaughtUp([](Simulation& sim) { return sim.base().Stop(); });
  }
  absl::StatusOr<BaseState> Read() override {
    return owner_.CaughtUp([](Simulation& sim) { return sim.base().Read(); });
  }
  double max_linear() const override { return owner_.options_.sim.max_linear; }
  double max_angular() const override { return owner_.options_.sim.max_angular; }

 private:
  RealTimeSimulation& owner_;
};

class RealTimeSimulation::Laser final : public LaserScanner {
 public:
  explicit Laser(RealTimeSimulation& owner) : owner_(owner) {}
  LaserLayout layout() const override { return owner_.sim_.laser_layout(); }
  // Waits for the next scan instant; a caller that fell behind gets the current one at once
  // (scans it missed are gone, as with a real sensor streaming continuously).
  absl::StatusOr<LaserReading> Read() override {
    double due;
    {
      std::lock_guard<std::mutex> lock(owner_.mutex_);
      due = owner_.next_scan_;
    }
    const double wait_wall = (due - owner_.SimTimeNow()) / owner_.options_.speed;
    if (wait_wall > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait_wall));
    std::lock_guard<std::mutex> lock(owner_.mutex_);
    owner_.CatchUpLocked();
    const double period = owner_.options_.scan_period;
    owner_.next_scan_ += period;
    if (owner_.next_scan_ <= owner_.sim_.now()) owner_.next_scan_ = owner_.sim_.now() + period;
    return owner_.sim_.laser().Read();
  }

 private:
  RealTimeSimulation& owner_;
};

RealTimeSimulation::RealTimeSimulation(World world, const RealTimeSimOptions& options, Clock clock)
    : options_(options),
      clock_(clock ? std::move(clock) : Clock(SteadySeconds)),
      sim_(std::move(world), options.sim),
      base_(std::make_unique<Base>(*this)),
      laser_(std::make_unique<Laser>(*this)) {
  if (!(options_.speed > 0)) options_.speed = 1.0;
  if (!(options_.scan_period > 0)) options_.scan_period = 0.1;
  wall_start_ = clock_();
}

RealTimeSimulation::~RealTimeSimulation() = default;

MobileBase& RealTimeSimulation::base() { return *base_; }
LaserScanner& RealTimeSimulation::laser() { return *laser_; }

double RealTimeSimulation::SimTimeNow() const { return (clock_() - wall_start_) * options_.speed; }

void RealTimeSimulation::CatchUpLocked() {
  const double target = SimTimeNow();
  if (target > sim_.now()) sim_.Advance(target - sim_.now());
}

BasePose RealTimeSimulation::true_pose() {
  return CaughtUp([](Simulation& sim) { return sim.true_pose(); });
}

int RealTimeSimulation::collisions() {
  return CaughtUp([](Simulation& sim) { return sim.collisions(); });
}

double RealTimeSimulation::distance_travelled() {
  return CaughtUp([](Simulation& sim) { return sim.distance_travelled(); });
}

double RealTimeSimulation::now() {
  return CaughtUp([](Simulation& sim) { return sim.now(); });
}

}  // namespace waymark::adapters
