// Standard SIP decoding and odometry unwrapping on hand-built packets.

#include "client/devices/p2os_sip.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace waymark::adapters {
namespace {

void Put16(std::vector<std::uint8_t>& p, int v) {
  p.push_back(static_cast<std::uint8_t>(v & 0xFF));
  p.push_back(static_cast<std::uint8_t>((v >> 8) & 0xFF));
}

P2osPacket Sip(int x, int y, int theta, int lvel, int rvel,
               std::vector<std::pair<int, int>> sonars = {}) {
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

// The encoder against the hand-built golden payload: an independent check of the byte layout.
TEST(P2osSipTest, EncoderReproducesTheHandBuiltPayload) {
  const P2osPacket golden = Sip(1000, 2000, 1024, -150, 200, {{0, 500}, {7, 5000}});
  StandardSip sip;
  sip.moving = true;
  sip.x_raw = 1000;
  sip.y_raw = 2000;
  sip.theta_raw = 1024;
  sip.left_velocity = -150;
  sip.right_velocity = 200;
  sip.battery_volts = 12.5;
  sip.left_stall = true;
  sip.front_bumpers = 0x02;
  sip.rear_bumpers = 0x01;
  sip.motors_enabled = true;
  sip.sonars = {{0, 500}, {7, 5000}};
  EXPECT_EQ(EncodeStandardSipPayload(sip), golden.payload);
}

TEST(P2osSipTest, EncodeThenDecodeRoundTrips) {
  StandardSip sip;
  sip.moving = false;
  sip.x_raw = 32767;
  sip.y_raw = 0;
  sip.theta_raw = -2047;
  sip.left_velocity = -32000;
  sip.right_velocity = 1;
  sip.battery_volts = 13.1;
  sip.right_stall = true;
  sip.front_bumpers = 0x7F;
  sip.rear_bumpers = 0x40;
  sip.motors_enabled = false;
  sip.sonars = {{15, 65535}, {3, 0}};
  P2osPacket packet;
  packet.id = 0x32;
  packet.payload = EncodeStandardSipPayload(sip);
  auto back = DecodeStandardSip(packet);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_FALSE(back->moving);
  EXPECT_EQ(back->x_raw, sip.x_raw);
  EXPECT_EQ(back->y_raw, sip.y_raw);
  EXPECT_EQ(back->theta_raw, sip.theta_raw);
  EXPECT_EQ(back->left_velocity, sip.left_velocity);
  EXPECT_EQ(back->right_velocity, sip.right_velocity);
  EXPECT_NEAR(back->battery_volts, 13.1, 1e-9);
  EXPECT_FALSE(back->left_stall);
  EXPECT_TRUE(back->right_stall);
  EXPECT_EQ(back->front_bumpers, 0x7F);
  EXPECT_EQ(back->rear_bumpers, 0x40);
  EXPECT_FALSE(back->motors_enabled);
  EXPECT_EQ(back->sonars, sip.sonars);
  // Counters beyond 15 bits wrap as on the robot.
  sip.x_raw = 32768 + 5;
  packet.payload = EncodeStandardSipPayload(sip);
  EXPECT_EQ(DecodeStandardSip(packet)->x_raw, 5);
}

}  // namespace
}  // namespace waymark::adapters
