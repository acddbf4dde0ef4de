#include "client/robot/safety_guard.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace waymark::cli {

const char* StopReasonName(StopReason reason) {
  switch (reason) {
    case StopReason::kCommandExpired:
      return "command expired";
    case StopReason::kStreamBroken:
      return "server stream broken";
    case StopReason::kBumper:
      return "bumper";
    case StopReason::kStall:
      return "wheel stall";
    case StopReason::kDeviceError:
      return "device error";
    case StopReason::kShutdown:
      return "shutdown";
    case StopReason::kCount:
      break;
  }
  return "unknown";
}

SafetyGuard::SafetyGuard(adapters::MobileBase& base, VelocityLimits limits, double time_scale,
                         double grace)
    : base_(base),
      limits_(limits),
      time_scale_(time_scale > 0 ? time_scale : 1.0),
      grace_(std::max(0.0, grace)) {
  limits_.max_linear = std::max(0.0, std::min(limits_.max_linear, base.max_linear()));
  limits_.max_angular = std::max(0.0, std::min(limits_.max_angular, base.max_angular()));
  watchdog_ = std::thread([this] { Watch(); });
}

SafetyGuard::~SafetyGuard() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
    StopLocked().IgnoreError();
  }
  changed_.notify_all();
  watchdog_.join();
}

absl::Status SafetyGuard::Drive(double linear, double angular, double valid_for) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!std::isfinite(linear) || !std::isfinite(angular) || !std::isfinite(valid_for)) {
    StopLocked().IgnoreError();
    return absl::InvalidArgumentError("velocity command must be finite");
  }
  if (valid_for <= 0 || (linear == 0 && angular == 0)) return StopLocked();
  linear_ = std::clamp(linear, -limits_.max_linear, limits_.max_linear);
  angular_ = std::clamp(angular, -limits_.max_angular, limits_.max_angular);
  const auto wall = std::chrono::duration<double>(valid_for / time_scale_ + grace_);
  deadline_ = std::chrono::steady_clock::now() +
              std::chrono::duration_cast<std::chrono::steady_clock::duration>(wall);
  moving_ = true;
  absl::Status s = base_.SetVelocity(linear_, angular_);
  if (!s.ok()) {
    StopLocked().IgnoreError();
    return s;
  }
  changed_.notify_all();
  return absl::OkStatus();
}

absl::Status SafetyGuard::StopLocked() {
  moving_ = false;
  linear_ = angular_ = 0;
  return base_.Stop();
}

absl::Status SafetyGuard::Stop() {
  std::lock_guard<std::mutex> lock(mutex_);
  return StopLocked();
}

absl::Status SafetyGuard::Halt(StopReason reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++stops_[static_cast<int>(reason)];
  return StopLocked();
}

void SafetyGuard::Watch() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!quit_) {
    if (!moving_) {
      changed_.wait(lock);
      continue;
    }
    if (std::chrono::steady_clock::now() >= deadline_) {
      ++stops_[static_cast<int>(StopReason::kCommandExpired)];
      StopLocked().IgnoreError();
      continue;
    }
    changed_.wait_until(lock, deadline_);
  }
}

bool SafetyGuard::moving() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return moving_;
}

double SafetyGuard::commanded_linear() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return linear_;
}

double SafetyGuard::commanded_angular() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return angular_;
}

std::uint64_t SafetyGuard::stops(StopReason reason) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stops_[static_cast<int>(reason)];
}

}  // namespace waymark::cli
