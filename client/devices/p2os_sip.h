#ifndef WAYMARK_CLIENT_DEVICES_P2OS_SIP_H_
#define WAYMARK_CLIENT_DEVICES_P2OS_SIP_H_

// The Pioneer's standard server information packet (SIP, ids 0x32 stopped / 0x33 moving, every
// 100 ms), decoded from a P2osPacket payload (p2os_packet.h), and the unwrapping of its 15-bit
// position counters into continuous SI odometry.
//
// Payload layout (ARCOS, little-endian 16-bit integers): XPOS, YPOS (mm, 15 bits, wrapping),
// THPOS (2 pi / 4096 rad units on the P3-DX), L VEL, R VEL (mm/s, signed), BATTERY (0.1 V, one
// byte), STALL AND BUMPERS (two bytes: bit 0 of each = left / right wheel stalled, bits 1-7 =
// front / rear bumpers), CONTROL, FLAGS (bit 0 = motors enabled), COMPASS (byte), SONAR COUNT
// (byte), then per sonar its number (byte) and range (mm). Later fields are not decoded.

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "client/devices/p2os_packet.h"

namespace waymark::adapters {

struct StandardSip {
  bool moving = false;  // id 0x33
  int x_raw = 0;        // 15-bit counters as sent
  int y_raw = 0;
  int theta_raw = 0;      // 2 pi / 4096 units
  int left_velocity = 0;  // mm/s
  int right_velocity = 0;
  double battery_volts = 0;
  bool left_stall = false;
  bool right_stall = false;
  std::uint8_t front_bumpers = 0;  // bit i = bumper i
  std::uint8_t rear_bumpers = 0;
  bool motors_enabled = false;
  std::vector<std::pair<int, int>> sonars;  // (number, range mm)
};

// INVALID_ARGUMENT for a packet that is not a standard SIP or is too short for what it claims.
absl::StatusOr<StandardSip> DecodeStandardSip(const P2osPacket& packet);

// The payload DecodeStandardSip reads (the packet id, 0x32 or 0x33 from `moving`, is not part of
// it): what a robot or a fake robot sends. Fields are truncated to their wire width (x/y to 15
// bits, velocities to 16, the battery to 0.1 V in a byte); CONTROL and COMPASS are sent as 0.
std::vector<std::uint8_t> EncodeStandardSipPayload(const StandardSip& sip);

// Turns the wrapping 15-bit x/y counters into continuous metres (each step assumed shorter than
// half the counter range, 16.4 m) and theta into radians.
class SipOdometry {
 public:
  struct Pose {
    double x = 0, y = 0, theta = 0;
  };
  Pose Update(const StandardSip& sip);

 private:
  bool started_ = false;
  int last_x_ = 0, last_y_ = 0;
  long long x_mm_ = 0, y_mm_ = 0;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_P2OS_SIP_H_
