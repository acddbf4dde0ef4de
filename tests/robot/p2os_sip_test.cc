// Standard SIP decoding and odometry unwrapping on hand-built packets.

#include "client/adapters/p2os_sip.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace waymark::adapters {
namespace {

void Put16(std::vector<std::uint8_t>& p, int v) {
  p.push_back(static_cast<std::uint8_t>(v & 0xFF));
  p.push_back(static_cast<std::uint8_t>((v >> 8) & 0xFF));
}

P2osPacket Sip(int x, int y, int theta, int lvel, int rvel, std::vector<std::pair<int, int>> sonars = {}) {
  P2osPacket packet;
  packet.id = 0x33;
  auto& p = packet.payload;
  Put16(p, x);
  Put16(p, y);
  Put16(p, theta);
  Put16(p, lvel);
  Put16(p, rvel);
  p.push_back(125);          // 12.5 V
  p.push_back(0x01 | 0x04);  // left stall, front bumper 1
  p.push_back(0x02);         // rear bumper 0
  Put16(p, 0);               // CONTROL
  Put16(p, 0x01);            // FLAGS: motors enabled
  p.push_back(0);            // COMPASS
  p.push_back(static_cast<std::uint8_t>(sonars.size()));
  for (auto [number, range] : sonars) {
    p.push_back(static_cast<std::uint8_t>(number));
    Put16(p, range);
  }
  return packet;
}

TEST(P2osSipTest, DecodesTheFixedFieldsAndSonars) {
  auto sip = DecodeStandardSip(Sip(1000, 2000, 1024, -150, 200, {{0, 500}, {7, 5000}}));
  ASSERT_TRUE(sip.ok()) << sip.status();
  EXPECT_TRUE(sip->moving);
  EXPECT_EQ(sip->x_raw, 1000);
  EXPECT_EQ(sip->y_raw, 2000);
  EXPECT_EQ(sip->theta_raw, 1024);
  EXPECT_EQ(sip->left_velocity, -150);
  EXPECT_EQ(sip->right_velocity, 200);
  EXPECT_DOUBLE_EQ(sip->battery_volts, 12.5);
  EXPECT_TRUE(sip->left_stall);
  EXPECT_FALSE(sip->right_stall);
  EXPECT_EQ(sip->front_bumpers, 0x02);
  EXPECT_EQ(sip->rear_bumpers, 0x01);
  EXPECT_TRUE(sip->motors_enabled);
  ASSERT_EQ(sip->sonars.size(), 2u);
  EXPECT_EQ(sip->sonars[1], std::make_pair(7, 5000));
}

TEST(P2osSipTest, RefusesOtherPacketsAndShortOnes) {
  P2osPacket other = Sip(0, 0, 0, 0, 0);
  other.id = 0x90;
  EXPECT_FALSE(DecodeStandardSip(other).ok());
  P2osPacket short_one = Sip(0, 0, 0, 0, 0, {{0, 1}});
  short_one.payload.resize(short_one.payload.size() - 2);  // a sonar reading cut off
  EXPECT_FALSE(DecodeStandardSip(short_one).ok());
  short_one.payload.resize(10);
  EXPECT_FALSE(DecodeStandardSip(short_one).ok());
}

TEST(P2osSipTest, OdometryUnwrapsThe15BitCounters) {
  SipOdometry odometry;
  // Driving +x across the wrap: 32700 -> 100 is +168 mm, not -32600.
  auto a = odometry.Update(*DecodeStandardSip(Sip(32700, 5, 0, 0, 0)));
  auto b = odometry.Update(*DecodeStandardSip(Sip(100, 5, 0, 0, 0)));
  EXPECT_NEAR(b.x - a.x, 0.168, 1e-9);
  // And back again.
  auto c = odometry.Update(*DecodeStandardSip(Sip(32760, 5, 2048, 0, 0)));
  EXPECT_NEAR(c.x - a.x, 0.060, 1e-9);
  EXPECT_NEAR(std::abs(c.theta), M_PI, 1e-9);  // 2048 units = half a turn
  auto d = odometry.Update(*DecodeStandardSip(Sip(32760, 5, 1024, 0, 0)));
  EXPECT_NEAR(d.theta, M_PI / 2, 1e-9);
}

}  // namespace
}  // namespace waymark::adapters
