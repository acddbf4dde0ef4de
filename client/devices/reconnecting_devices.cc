#include "client/devices/reconnecting_devices.h"

#include "absl/strings/str_cat.h"

namespace waymark::adapters {

absl::StatusOr<std::unique_ptr<ReconnectingBase>> ReconnectingBase::Create(
    Factory factory, absl::Duration retry_interval) {
  std::unique_ptr<ReconnectingBase> base(new ReconnectingBase(std::move(factory), retry_interval));
  if (absl::Status s = base->reconnector_.Connect(); !s.ok()) return s;
  base->reconnector_.With(
      [&](MobileBase& device) {
        base->max_linear_ = device.max_linear();
        base->max_angular_ = device.max_angular();
        return absl::OkStatus();
      },
      /*may_reconnect=*/false);
  return base;
}

absl::Status ReconnectingBase::SetVelocity(double linear, double angular) {
  return reconnector_.With([&](MobileBase& d) { return d.SetVelocity(linear, angular); },
                           /*may_reconnect=*/false);
}

absl::Status ReconnectingBase::Stop() {
  return reconnector_.With([](MobileBase& d) { return d.Stop(); }, /*may_reconnect=*/false);
}

absl::StatusOr<BaseState> ReconnectingBase::Read() {
  return reconnector_.With([](MobileBase& d) { return d.Read(); }, /*may_reconnect=*/true);
}

namespace {

bool SameLayout(const LaserLayout& a, const LaserLayout& b) {
  return a.beam_count == b.beam_count && a.angle_min == b.angle_min &&
         a.angle_increment == b.angle_increment && a.no_return_range == b.no_return_range;
}

}  // namespace

ReconnectingLaser::ReconnectingLaser(Factory factory, absl::Duration retry_interval)
    : reconnector_(std::move(factory), retry_interval, [this](LaserScanner& device) {
        const LaserLayout layout = device.layout();
        if (!have_layout_) {
          layout_ = layout;
          have_layout_ = true;
          return absl::OkStatus();
        }
        if (SameLayout(layout, layout_)) return absl::OkStatus();
        return absl::FailedPreconditionError(absl::StrCat(
            "the laser came back with ", layout.beam_count, " beams where the session has ",
            layout_.beam_count, ": restart the robot with the old settings"));
      }) {}

absl::StatusOr<std::unique_ptr<ReconnectingLaser>> ReconnectingLaser::Create(
    Factory factory, absl::Duration retry_interval) {
  std::unique_ptr<ReconnectingLaser> laser(
      new ReconnectingLaser(std::move(factory), retry_interval));
  if (absl::Status s = laser->reconnector_.Connect(); !s.ok()) return s;
  return laser;
}

absl::StatusOr<LaserReading> ReconnectingLaser::Read() {
  return reconnector_.With([](LaserScanner& d) { return d.Read(); }, /*may_reconnect=*/true);
}

}  // namespace waymark::adapters
