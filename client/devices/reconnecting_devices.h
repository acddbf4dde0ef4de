#ifndef WAYMARK_CLIENT_DEVICES_RECONNECTING_DEVICES_H_
#define WAYMARK_CLIENT_DEVICES_RECONNECTING_DEVICES_H_

// Devices that come back after an unplugged cable: a base or laser whose link fails
// (UNAVAILABLE) is dropped and reconnected through its factory, at most once per
// `retry_interval`, while callers keep getting UNAVAILABLE (the robot loop stops the base and
// waits). Other errors pass through. Reconnecting happens on Read() only (the loop polls it);
// commands to a device that is gone fail at once. A laser must come back with the layout it had:
// one that returns configured differently is refused (FAILED_PRECONDITION) rather than fed to a
// session that expects the old beams.

#include <functional>
#include <memory>
#include <mutex>
#include <utility>

#include "absl/status/statusor.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "client/devices/robot_devices.h"

namespace waymark::adapters {

// The reconnect logic both wrappers share.
template <typename Device>
class DeviceReconnector {
 public:
  using Factory = std::function<absl::StatusOr<std::unique_ptr<Device>>()>;
  // Accepts or refuses a freshly connected device.
  using Accept = std::function<absl::Status(Device&)>;

  DeviceReconnector(Factory factory, absl::Duration retry_interval, Accept accept = {})
      : factory_(std::move(factory)), retry_interval_(retry_interval), accept_(std::move(accept)) {}

  // Connects now (the first time); the error if that fails.
  absl::Status Connect() {
    std::lock_guard<std::mutex> lock(mutex_);
    return ConnectLocked();
  }

  // Runs `use(Device&)` (returning absl::Status or absl::StatusOr<T>) on the connected device. A
  // link failure drops the device; with `may_reconnect`, a missing device is reconnected first
  // when the retry interval has passed.
  template <typename F>
  auto With(F&& use, bool may_reconnect) -> decltype(use(std::declval<Device&>())) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!device_ && may_reconnect && absl::Now() >= next_attempt_) {
      if (ConnectLocked().ok()) ++reconnects_;
    }
    if (!device_) return last_error_;
    auto result = use(*device_);
    if (StatusOf(result).code() == absl::StatusCode::kUnavailable) {
      last_error_ = StatusOf(result);
      device_.reset();  // its destructor says goodbye as well as a dead link allows
      next_attempt_ = absl::Now() + retry_interval_;
    }
    return result;
  }

  int reconnects() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return reconnects_;
  }

 private:
  static absl::Status StatusOf(const absl::Status& s) { return s; }
  template <typename T>
  static absl::Status StatusOf(const absl::StatusOr<T>& s) {
    return s.status();
  }

  absl::Status ConnectLocked() {
    next_attempt_ = absl::Now() + retry_interval_;
    absl::StatusOr<std::unique_ptr<Device>> device = factory_();
    absl::Status status = device.ok() ? absl::OkStatus() : device.status();
    if (status.ok() && accept_) status = accept_(**device);
    if (!status.ok()) {
      // Keep callers on UNAVAILABLE-style errors while the device is away, whatever the factory
      // said (a missing /dev node is NOT_FOUND while the cable is out).
      last_error_ = status.code() == absl::StatusCode::kFailedPrecondition
                        ? status
                        : absl::UnavailableError(status.message());
      return status;
    }
    device_ = *std::move(device);
    return absl::OkStatus();
  }

  Factory factory_;
  absl::Duration retry_interval_;
  Accept accept_;
  mutable std::mutex mutex_;
  std::unique_ptr<Device> device_;
  absl::Status last_error_ = absl::UnavailableError("not connected");
  absl::Time next_attempt_ = absl::InfinitePast();
  int reconnects_ = 0;
};

class ReconnectingBase final : public MobileBase {
 public:
  using Factory = DeviceReconnector<MobileBase>::Factory;
  static absl::StatusOr<std::unique_ptr<ReconnectingBase>> Create(
      Factory factory, absl::Duration retry_interval = absl::Seconds(1));

  absl::Status SetVelocity(double linear, double angular) override;
  absl::Status Stop() override;
  absl::StatusOr<BaseState> Read() override;
  double max_linear() const override { return max_linear_; }
  double max_angular() const override { return max_angular_; }
  int reconnects() const { return reconnector_.reconnects(); }

 private:
  ReconnectingBase(Factory factory, absl::Duration retry_interval)
      : reconnector_(std::move(factory), retry_interval) {}
  DeviceReconnector<MobileBase> reconnector_;
  double max_linear_ = 0;
  double max_angular_ = 0;
};

class ReconnectingLaser final : public LaserScanner {
 public:
  using Factory = DeviceReconnector<LaserScanner>::Factory;
  static absl::StatusOr<std::unique_ptr<ReconnectingLaser>> Create(
      Factory factory, absl::Duration retry_interval = absl::Seconds(1));

  LaserLayout layout() const override { return layout_; }
  absl::StatusOr<LaserReading> Read() override;
  int reconnects() const { return reconnector_.reconnects(); }

 private:
  ReconnectingLaser(Factory factory, absl::Duration retry_interval);
  DeviceReconnector<LaserScanner> reconnector_;
  LaserLayout layout_;
  bool have_layout_ = false;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_RECONNECTING_DEVICES_H_
