#include "client/sim/sim_robot.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "client/sim/sim_geometry.h"

namespace waymark::adapters {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDefaultStep = 0.01;
// A contact ends once the body is this far (m) beyond body_radius from every wall, so sliding
// along a wall or nudging it again before backing off is one collision, not many.
constexpr double kContactRelease = 0.01;

// A standard normal number by Box-Muller from 53-bit uniforms: the same sequence on every
// standard library, not just libstdc++.
double StandardNormal(std::mt19937_64& rng) {
  const double u1 = 1.0 - static_cast<double>(rng() >> 11) * 0x1.0p-53;  // (0, 1]
  const double u2 = static_cast<double>(rng() >> 11) * 0x1.0p-53;        // [0, 1)
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

}  // namespace

class Simulation::Base final : public MobileBase {
 public:
  explicit Base(Simulation& sim) : sim_(sim) {}

  absl::Status SetVelocity(double linear, double angular) override {
    if (!std::isfinite(linear) || !std::isfinite(angular)) {
      return absl::InvalidArgumentError("velocity command must be finite");
    }
    sim_.cmd_linear_ = std::clamp(linear, -max_linear(), max_linear());
    sim_.cmd_angular_ = std::clamp(angular, -max_angular(), max_angular());
    return absl::OkStatus();
  }

  absl::Status Stop() override {
    sim_.cmd_linear_ = 0;
    sim_.cmd_angular_ = 0;
    return absl::OkStatus();
  }

  absl::StatusOr<BaseState> Read() override {
    BaseState state;
    state.stamp = sim_.time_;
    state.odometry = sim_.odometry_;
    state.linear = sim_.linear_;
    state.angular = sim_.angular_;
    state.bumped = sim_.bumped_;
    state.stalled = false;
    state.motors_enabled = true;
    return state;
  }

  double max_linear() const override { return sim_.options_.max_linear; }
  double max_angular() const override { return sim_.options_.max_angular; }

 private:
  Simulation& sim_;
};

class Simulation::Laser final : public LaserScanner {
 public:
  explicit Laser(Simulation& sim) : sim_(sim) {}
  LaserLayout layout() const override { return sim_.laser_layout(); }
  absl::StatusOr<LaserReading> Read() override { return sim_.Scan(); }

 private:
  Simulation& sim_;
};

Simulation::Simulation(World world, const SimOptions& options)
    : world_(std::move(world)),
      options_(options),
      rng_(options.seed),
      base_(std::make_unique<Base>(*this)),
      laser_(std::make_unique<Laser>(*this)) {
  // A step that is not a positive finite number would never finish Advance().
  if (!(options_.step > 0) || !std::isfinite(options_.step)) options_.step = kDefaultStep;
  options_.max_linear = std::abs(options_.max_linear);
  options_.max_angular = std::abs(options_.max_angular);
  pose_ = options_.start.value_or(world_.start);
  pose_.theta = geometry::WrapAngle(pose_.theta);
  odometry_ = pose_;  // the odometry frame is the world frame at the start
}

Simulation::~Simulation() = default;

MobileBase& Simulation::base() { return *base_; }
LaserScanner& Simulation::laser() { return *laser_; }

void Simulation::Advance(double seconds) {
  if (!(seconds > 0) || !std::isfinite(seconds)) return;
  const double step = options_.step;
  // Whole steps, then one shorter step for the rest; a rest within rounding of 0 or of a whole
  // step is folded in, so Advance(10) at step 0.01 is exactly 1000 steps.
  double whole = std::floor(seconds / step);
  double rest = seconds - whole * step;
  if (rest > step * (1 - 1e-9)) {
    whole += 1;
    rest = 0;
  } else if (rest < step * 1e-9) {
    rest = 0;
  }
  const double start = time_;
  for (double i = 0; i < whole; i += 1) Step(step);
  if (rest > 0) Step(rest);
  time_ = start + seconds;
}

void Simulation::Step(double dt) {
  const double linear = cmd_linear_;
  const double angular = cmd_angular_;
  double distance = linear * dt;
  const double turn = angular * dt;

  // Collision: the body disc may not come within body_radius of a wall. A step that would is not
  // taken (rotation in place is: it does not move the disc). A step that increases the clearance
  // is always allowed, so a robot that starts too close can still get away.
  BasePose next = pose_;
  geometry::ApplyArc(next, distance, turn);
  if (distance != 0) {
    const double radius = options_.body_radius;
    const double clearance = ClearanceAt(next.x, next.y);
    const bool blocked = clearance < radius && clearance < ClearanceAt(pose_.x, pose_.y);
    if (blocked) {
      if (!bumped_) ++collisions_;  // one collision per contact
      bumped_ = true;
      distance = 0;
      next = pose_;
      geometry::ApplyArc(next, 0, turn);
    } else if (bumped_ && clearance > radius + kContactRelease) {
      bumped_ = false;  // moved clear of the wall: the contact is over
    }
  }
  pose_ = next;
  linear_ = distance != 0 ? linear : 0;
  angular_ = angular;
  travelled_ += std::abs(distance);

  // Odometry: systematic scale and drift, plus Gaussian noise whose variance grows with the
  // distance (angle) of the step, so the error over a path does not depend on the step size.
  const OdometryError& e = options_.odometry;
  const double n_distance = StandardNormal(rng_);
  const double n_turn = StandardNormal(rng_);
  const double n_turn_per_m = StandardNormal(rng_);
  const double odo_distance =
      distance * e.distance_scale + e.distance_sigma * std::sqrt(std::abs(distance)) * n_distance;
  const double odo_turn = turn * e.turn_scale + e.drift_per_m * distance +
                          e.turn_sigma * std::sqrt(std::abs(turn)) * n_turn +
                          e.turn_per_m_sigma * std::sqrt(std::abs(distance)) * n_turn_per_m;
  geometry::ApplyArc(odometry_, odo_distance, odo_turn);
  time_ += dt;
}

double Simulation::ClearanceAt(double x, double y) const {
  double clearance = geometry::Clearance(world_.walls, x, y);
  for (const OtherBody& b : others_) {
    clearance = std::min(clearance, std::hypot(x - b.x, y - b.y) - b.radius);
  }
  return clearance;
}

namespace {

// Distance along the ray (ox, oy) + t (dx, dy), unit (dx, dy), to the circle; +infinity when it
// misses (or starts inside it).
double RayDiscHit(double ox, double oy, double dx, double dy, const OtherBody& b) {
  const double fx = ox - b.x, fy = oy - b.y;
  const double along = fx * dx + fy * dy;
  const double c = fx * fx + fy * fy - b.radius * b.radius;
  const double disc = along * along - c;
  if (c <= 0 || disc < 0) return std::numeric_limits<double>::infinity();
  const double t = -along - std::sqrt(disc);
  return t >= 0 ? t : std::numeric_limits<double>::infinity();
}

}  // namespace

LaserLayout Simulation::laser_layout() const {
  LaserLayout layout;
  layout.angle_min = -kPi / 2;
  layout.angle_increment = options_.half_degree ? kPi / 360 : kPi / 180;
  layout.beam_count = options_.half_degree ? 361 : 181;
  layout.no_return_range = options_.no_return_range;
  layout.mount = options_.laser_mount;
  return layout;
}

LaserReading Simulation::Scan() {
  const LaserLayout layout = laser_layout();
  const BasePose laser = geometry::Compose(pose_, layout.mount);
  LaserReading reading;
  reading.stamp = time_;
  reading.ranges.reserve(layout.beam_count);
  for (std::uint32_t i = 0; i < layout.beam_count; ++i) {
    const double bearing = laser.theta + layout.angle_min + i * layout.angle_increment;
    double hit = geometry::CastRay(world_.walls, laser.x, laser.y, std::cos(bearing),
                                   std::sin(bearing));
    for (const OtherBody& b : others_) {
      hit = std::min(hit, RayDiscHit(laser.x, laser.y, std::cos(bearing), std::sin(bearing), b));
    }
    double range = options_.no_return_range;
    if (hit <= options_.max_range) {
      range = std::max(0.0, hit + options_.range_sigma * StandardNormal(rng_));
      range = std::round(range * 1000) / 1000;
    }
    reading.ranges.push_back(static_cast<float>(range));
  }
  return reading;
}

}  // namespace waymark::adapters
