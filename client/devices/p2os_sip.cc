#include "client/devices/p2os_sip.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace waymark::adapters {
namespace {

constexpr std::uint8_t kSipStopped = 0x32;
constexpr std::uint8_t kSipMoving = 0x33;
constexpr int kCounterBits = 15;
constexpr int kCounterRange = 1 << kCounterBits;
constexpr double kThetaUnit = 2.0 * M_PI / 4096.0;

int Int16(const std::vector<std::uint8_t>& p, std::size_t at) {
  return static_cast<std::int16_t>(p[at] | (p[at + 1] << 8));
}
int Uint16(const std::vector<std::uint8_t>& p, std::size_t at) { return p[at] | (p[at + 1] << 8); }

// Difference of two wrapping counters, in (-range/2, range/2].
void Put16(std::vector<std::uint8_t>& p, int v) {
  p.push_back(static_cast<std::uint8_t>(v & 0xFF));
  p.push_back(static_cast<std::uint8_t>((v >> 8) & 0xFF));
}

int WrapDelta(int now, int before) {
  int d = (now - before) % kCounterRange;
  if (d > kCounterRange / 2) d -= kCounterRange;
  if (d <= -kCounterRange / 2) d += kCounterRange;
  return d;
}

}  // namespace

absl::StatusOr<StandardSip> DecodeStandardSip(const P2osPacket& packet) {
  if (packet.id != kSipStopped && packet.id != kSipMoving) {
    return absl::InvalidArgumentError(
        absl::StrCat("packet id 0x", absl::Hex(packet.id), " is not a standard SIP"));
  }
  const std::vector<std::uint8_t>& p = packet.payload;
  constexpr std::size_t kFixed = 19;  // XPOS .. SONAR COUNT
  if (p.size() < kFixed) {
    return absl::InvalidArgumentError(absl::StrCat(
        "standard SIP of ", p.size(), " bytes is shorter than its ", kFixed, " fixed bytes"));
  }
  StandardSip sip;
  sip.moving = packet.id == kSipMoving;
  sip.x_raw = Uint16(p, 0) & (kCounterRange - 1);
  sip.y_raw = Uint16(p, 2) & (kCounterRange - 1);
  sip.theta_raw = Int16(p, 4);
  sip.left_velocity = Int16(p, 6);
  sip.right_velocity = Int16(p, 8);
  sip.battery_volts = p[10] / 10.0;
  sip.left_stall = p[11] & 0x01;
  sip.front_bumpers = static_cast<std::uint8_t>(p[11] >> 1);
  sip.right_stall = p[12] & 0x01;
  sip.rear_bumpers = static_cast<std::uint8_t>(p[12] >> 1);
  // p[13..14] CONTROL
  sip.motors_enabled = Uint16(p, 15) & 0x01;
  // p[17] COMPASS
  const int sonar_count = p[18];
  // Sonar readings (number, range) are 3 bytes each from byte 19 on.
  if (p.size() < 19 + 3u * sonar_count) {
    return absl::InvalidArgumentError(absl::StrCat("standard SIP claims ", sonar_count,
                                                   " sonar readings but has room for ",
                                                   (p.size() - 19) / 3));
  }
  for (int i = 0; i < sonar_count; ++i) {
    const std::size_t at = 19 + 3u * i;
    sip.sonars.emplace_back(p[at], Uint16(p, at + 1));
  }
  return sip;
}

std::vector<std::uint8_t> EncodeStandardSipPayload(const StandardSip& sip) {
  std::vector<std::uint8_t> p;
  p.reserve(19 + 3 * sip.sonars.size());
  Put16(p, sip.x_raw & (kCounterRange - 1));
  Put16(p, sip.y_raw & (kCounterRange - 1));
  Put16(p, sip.theta_raw);
  Put16(p, sip.left_velocity);
  Put16(p, sip.right_velocity);
  const long decivolts = std::lround(sip.battery_volts * 10.0);
  p.push_back(static_cast<std::uint8_t>(std::clamp(decivolts, 0L, 255L)));
  p.push_back(static_cast<std::uint8_t>((sip.front_bumpers << 1) | (sip.left_stall ? 1 : 0)));
  p.push_back(static_cast<std::uint8_t>((sip.rear_bumpers << 1) | (sip.right_stall ? 1 : 0)));
  Put16(p, 0);                                 // CONTROL
  Put16(p, sip.motors_enabled ? 0x01 : 0x00);  // FLAGS
  p.push_back(0);                              // COMPASS
  // The count is one byte: at most 255 readings, and the 200-byte packet limit is the caller's.
  const std::size_t sonar_count = std::min<std::size_t>(sip.sonars.size(), 255);
  p.push_back(static_cast<std::uint8_t>(sonar_count));
  for (std::size_t i = 0; i < sonar_count; ++i) {
    p.push_back(static_cast<std::uint8_t>(sip.sonars[i].first));
    Put16(p, sip.sonars[i].second);
  }
  return p;
}

SipOdometry::Pose SipOdometry::Update(const StandardSip& sip) {
  if (started_) {
    x_mm_ += WrapDelta(sip.x_raw, last_x_);
    y_mm_ += WrapDelta(sip.y_raw, last_y_);
  } else {
    x_mm_ = sip.x_raw;
    y_mm_ = sip.y_raw;
    started_ = true;
  }
  last_x_ = sip.x_raw;
  last_y_ = sip.y_raw;
  const double theta = std::remainder(sip.theta_raw * kThetaUnit, 2.0 * M_PI);
  return Pose{x_mm_ / 1000.0, y_mm_ / 1000.0, theta};
}

}  // namespace waymark::adapters
