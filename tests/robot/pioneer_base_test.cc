// The Pioneer base driver against a fake ARCOS controller on a pseudo-terminal: handshake bytes,
// a robot left open, odometry, clamps, the watchdog, bad bytes, flags, and a dying link.

#include "client/devices/pioneer_base.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>

#include "client/devices/p2os_packet.h"
#include "client/devices/serial_port.h"
#include "tests/robot/eventually.h"
#include "tests/robot/fake_arcos_peer.h"

namespace waymark::adapters {
namespace {

using testing::FakeArcosOptions;
using testing::FakeArcosPeer;
using testing::PtyPair;
using Commands = std::vector<FakeArcosPeer::Command>;

constexpr absl::Duration kPatience = absl::Seconds(5);

std::unique_ptr<FakeArcosPeer> StartPeer(const FakeArcosOptions& options = {}) {
  auto pty = PtyPair::Open();
  if (!pty.ok()) {
    ADD_FAILURE() << pty.status();
    return nullptr;
  }
  return std::make_unique<FakeArcosPeer>(std::move(*pty), options);
}

using testing::Eventually;

bool HasCommand(const Commands& log, const std::string& name, int arg) {
  for (const auto& c : log) {
    if (c.name == name && c.has_arg && c.arg == arg) return true;
  }
  return false;
}

std::vector<std::uint8_t> Concat(const std::vector<std::vector<std::uint8_t>>& packets) {
  std::vector<std::uint8_t> out;
  for (const auto& p : packets) out.insert(out.end(), p.begin(), p.end());
  return out;
}

TEST(PioneerBaseTest, HandshakeBytesAreExact) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  // SYNC0 SYNC1 SYNC2 OPEN PULSE ENABLE(1) SETO, as the wire carries them.
  const std::vector<std::uint8_t> expected = Concat({
      {0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00},
      {0xFA, 0xFB, 0x03, 0x01, 0x00, 0x01},
      {0xFA, 0xFB, 0x03, 0x02, 0x00, 0x02},
      {0xFA, 0xFB, 0x03, 0x01, 0x00, 0x01},
      {0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00},
      {0xFA, 0xFB, 0x06, 0x04, 0x3B, 0x01, 0x00, 0x05, 0x3B},
      {0xFA, 0xFB, 0x03, 0x07, 0x00, 0x07},
  });
  const std::vector<std::uint8_t> got = peer->received_bytes();
  ASSERT_GE(got.size(), expected.size());
  EXPECT_EQ(std::vector<std::uint8_t>(got.begin(), got.begin() + expected.size()), expected);
  EXPECT_TRUE(peer->is_open());
  EXPECT_TRUE(peer->motors_enabled());

  const PioneerBase::LinkStats link = (*base)->link();
  EXPECT_EQ(link.robot_name, "waymark-fake");
  EXPECT_EQ(link.robot_class, "Pioneer");
  EXPECT_EQ(link.robot_subclass, "p3dx-sh");
  EXPECT_GE(link.sips, 1u);
  EXPECT_TRUE(link.error.empty());
  auto state = (*base)->Read();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_TRUE(state->motors_enabled);
  EXPECT_NEAR(state->battery_volts, 12.6, 0.05);  // the fake's battery, in 0.1 V units
  EXPECT_GT(state->stamp, 1e9);                   // host clock, seconds since the epoch
}

TEST(PioneerBaseTest, RobotLeftOpenIsClosedAndResynchronised) {
  FakeArcosOptions options;
  options.left_open = true;  // streaming SIPs at (1.234, -0.567) and ignoring syncs
  options.name = "left-open";
  auto peer = StartPeer(options);
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  EXPECT_GE(peer->Count("CLOSE"), 1);
  EXPECT_EQ(peer->Count("SYNC2"), 1);
  EXPECT_TRUE(peer->is_open());
  EXPECT_EQ((*base)->link().robot_name, "left-open");
  // SETO took effect before odometry started: no jump from the old pose.
  auto state = (*base)->Read();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_NEAR(state->odometry.x, 0, 1e-3);
  EXPECT_NEAR(state->odometry.y, 0, 1e-3);
  EXPECT_NEAR(state->odometry.theta, 0, 1e-3);
}

TEST(PioneerBaseTest, OdometryFollowsCommandsInSiUnits) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  PioneerBase& b = **base;

  ASSERT_TRUE(b.SetVelocity(0.3, 0).ok());
  ASSERT_TRUE(
      peer->WaitFor([](const Commands& c) { return HasCommand(c, "VEL", 300); }, kPatience));
  EXPECT_TRUE(Eventually([&] {
    auto s = b.Read();
    return s.ok() && std::abs(s->linear - 0.3) < 1e-6 && std::abs(s->angular) < 1e-6;
  }));
  ASSERT_TRUE(Eventually([&] { return peer->pose().x > 0.15; }));  // ~0.5 s of driving
  ASSERT_TRUE(b.Stop().ok());
  ASSERT_TRUE(peer->WaitFor([](const Commands& c) { return HasCommand(c, "VEL", 0); }, kPatience));
  // Stopped: the driver's odometry converges on the robot's pose, in metres.
  EXPECT_TRUE(Eventually([&] {
    auto s = b.Read();
    const auto truth = peer->pose();
    return s.ok() && s->linear == 0 && std::abs(s->odometry.x - truth.x) < 0.002 &&
           std::abs(s->odometry.y - truth.y) < 0.002;
  }));
  auto s = b.Read();
  ASSERT_TRUE(s.ok());
  EXPECT_GT(s->odometry.x, 0.15);
  // Metres, not millimetres (that would be >= 150). Not a tighter bound: how far the robot rolls
  // between the 0.15 m seen and the stop depends on how quickly this thread runs again.
  EXPECT_LT(s->odometry.x, 100.0);

  // Turning: 0.5 rad/s is RVEL 29 deg/s; the angular velocity comes back from the wheel speeds.
  ASSERT_TRUE(b.SetVelocity(0, 0.5).ok());
  ASSERT_TRUE(
      peer->WaitFor([](const Commands& c) { return HasCommand(c, "RVEL", 29); }, kPatience));
  EXPECT_TRUE(Eventually([&] {
    auto st = b.Read();
    return st.ok() && std::abs(st->angular - 29 * M_PI / 180) < 0.01 && std::abs(st->linear) < 1e-6;
  }));
  ASSERT_TRUE(Eventually([&] { return peer->pose().theta > 0.3; }));
  ASSERT_TRUE(b.Stop().ok());
  EXPECT_TRUE(Eventually([&] {
    auto st = b.Read();
    return st.ok() && st->angular == 0 && std::abs(st->odometry.theta - peer->pose().theta) < 0.003;
  }));
}

TEST(PioneerBaseTest, VelocitiesAreClampedToTheLimits) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  EXPECT_DOUBLE_EQ((*base)->max_linear(), 0.5);
  EXPECT_DOUBLE_EQ((*base)->max_angular(), 1.0);
  ASSERT_TRUE((*base)->SetVelocity(5.0, 10.0).ok());
  // 0.5 m/s = 500 mm/s; 1 rad/s = 57.3 deg/s, rounded.
  EXPECT_TRUE(peer->WaitFor(
      [](const Commands& c) { return HasCommand(c, "VEL", 500) && HasCommand(c, "RVEL", 57); },
      kPatience));
  ASSERT_TRUE((*base)->SetVelocity(-5.0, -10.0).ok());
  EXPECT_TRUE(peer->WaitFor(
      [](const Commands& c) { return HasCommand(c, "VEL", -500) && HasCommand(c, "RVEL", -57); },
      kPatience));
  for (const auto& c : peer->commands()) {
    if (c.name == "VEL") {
      EXPECT_LE(std::abs(c.arg), 500);
    }
    if (c.name == "RVEL") {
      EXPECT_LE(std::abs(c.arg), 57);
    }
  }
  EXPECT_EQ((*base)->SetVelocity(NAN, 0).code(), absl::StatusCode::kInvalidArgument);

  PioneerOptions options;
  options.max_linear = 0.25;
  options.max_angular = 0.2;
  auto peer2 = StartPeer();
  ASSERT_NE(peer2, nullptr);
  auto slow = PioneerBase::Connect(peer2->device_path(), options);
  ASSERT_TRUE(slow.ok()) << slow.status();
  ASSERT_TRUE((*slow)->SetVelocity(1.0, 1.0).ok());
  EXPECT_TRUE(peer2->WaitFor(
      [](const Commands& c) { return HasCommand(c, "VEL", 250) && HasCommand(c, "RVEL", 11); },
      kPatience));
}

TEST(PioneerBaseTest, EmergencyStopSendsEstop) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  ASSERT_TRUE((*base)->EmergencyStop().ok());
  EXPECT_TRUE(peer->WaitFor(
      [](const Commands& c) { return !c.empty() && c.back().name == "ESTOP"; }, kPatience));
}

TEST(PioneerBaseTest, PulsesKeepTheWatchdogFromTripping) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  ASSERT_TRUE((*base)->SetVelocity(0.1, 0).ok());
  const int pulses_before = peer->Count("PULSE");
  // No commands from the caller while the driver pulses on its own: five pulses (2.5 s at the
  // 500 ms interval) outlast the robot's 2 s watchdog. Counted, not slept for: on a loaded
  // machine the 2.5 s may hold fewer pulses, which is not what this test is about.
  EXPECT_TRUE(Eventually([&] { return peer->Count("PULSE") - pulses_before >= 5; }));
  EXPECT_EQ(peer->watchdog_trips(), 0);
  auto state = (*base)->Read();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_NEAR(state->linear, 0.1, 1e-6);  // still driving
}

// The fake's watchdog itself, driven by hand: without PULSEs the robot stops. This is what the
// previous test would see if the driver stopped pulsing.
TEST(PioneerBaseTest, FakeWatchdogStopsARobotLeftWithoutPulses) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto port = SerialPort::Open(peer->device_path(), 9600);
  ASSERT_TRUE(port.ok()) << port.status();
  for (std::uint8_t id : {p2os::kSync0, p2os::kSync1, p2os::kSync2, p2os::kOpen}) {
    ASSERT_TRUE((*port)->Write(EncodeP2osCommand(id)).ok());
  }
  ASSERT_TRUE((*port)->Write(*EncodeP2osCommand(p2os::kEnable, 1)).ok());
  // VEL2: left and right wheel 10 x 20 mm/s each.
  ASSERT_TRUE((*port)->Write(*EncodeP2osCommand(p2os::kVel2, (10 << 8) | 10)).ok());
  ASSERT_TRUE(Eventually([&] { return peer->pose().x > 0.05; }));
  ASSERT_TRUE(Eventually([&] { return peer->watchdog_trips() == 1; }));
  const double x = peer->pose().x;
  absl::SleepFor(absl::Milliseconds(300));
  EXPECT_DOUBLE_EQ(peer->pose().x, x);  // stopped
  (*port)->DiscardInput();
}

TEST(PioneerBaseTest, GarbageAndBadChecksumsAreCountedAndSurvived) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  const PioneerBase::LinkStats before = (*base)->link();
  std::vector<std::uint8_t> garbage;
  for (int i = 0; i < 100; ++i) garbage.push_back(static_cast<std::uint8_t>(i % 0xF0));
  peer->InjectBytes(garbage);
  for (int i = 0; i < 3; ++i) peer->InjectCorruptSip();
  peer->InjectBytes({0xFA, 0xFB, 0xFF, 0x00});  // impossible count
  EXPECT_TRUE(Eventually([&] {
    const PioneerBase::LinkStats now = (*base)->link();
    return now.bad_checksums >= before.bad_checksums + 3 &&
           now.skipped_bytes >= before.skipped_bytes + 100 && now.bad_counts > before.bad_counts;
  })) << (*base)->link().bad_checksums
      << " " << (*base)->link().skipped_bytes;
  // Still alive: fresh SIPs keep coming and Read() works.
  const std::uint64_t sips = (*base)->link().sips;
  EXPECT_TRUE(Eventually([&] { return (*base)->link().sips >= sips + 3; }));
  EXPECT_TRUE((*base)->Read().ok());
  EXPECT_TRUE((*base)->link().error.empty());
}

TEST(PioneerBaseTest, BumperAndStallFlagsReachTheState) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  auto state = (*base)->Read();
  ASSERT_TRUE(state.ok());
  EXPECT_FALSE(state->bumped);
  EXPECT_FALSE(state->stalled);
  peer->SetBumpers(0x00, 0x10);  // one rear bumper
  EXPECT_TRUE(Eventually([&] {
    auto s = (*base)->Read();
    return s.ok() && s->bumped && !s->stalled;
  }));
  peer->SetBumpers(0, 0);
  peer->SetStall(false, true);
  EXPECT_TRUE(Eventually([&] {
    auto s = (*base)->Read();
    return s.ok() && !s->bumped && s->stalled;
  }));
  peer->SetStall(false, false);
  EXPECT_TRUE(Eventually([&] {
    auto s = (*base)->Read();
    return s.ok() && !s->bumped && !s->stalled;
  }));
}

TEST(PioneerBaseTest, UnpluggedCableMakesReadUnavailable) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  ASSERT_TRUE((*base)->Read().ok());
  peer->Hangup();
  absl::Status status;
  EXPECT_TRUE(Eventually([&] {
    status = (*base)->Read().status();
    return !status.ok();
  }));
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_NE(status.message().find(peer->device_path()), std::string::npos) << status;
  EXPECT_NE(status.message().find("disconnected"), std::string::npos) << status;
  EXPECT_FALSE((*base)->link().error.empty());
  EXPECT_EQ((*base)->SetVelocity(0.1, 0).code(), absl::StatusCode::kUnavailable);
  base->reset();  // the destructor copes with a dead link
}

TEST(PioneerBaseTest, StoppedSipsMakeReadUnavailable) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  PioneerOptions options;
  options.sip_timeout = absl::Milliseconds(500);
  auto base = PioneerBase::Connect(peer->device_path(), options);
  ASSERT_TRUE(base.ok()) << base.status();
  ASSERT_TRUE((*base)->Read().ok());
  peer->PauseSips(true);
  absl::Status status;
  EXPECT_TRUE(Eventually([&] {
    status = (*base)->Read().status();
    return !status.ok();
  }));
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_NE(status.message().find("no SIP"), std::string::npos) << status;
  peer->PauseSips(false);
  EXPECT_TRUE(Eventually([&] { return (*base)->Read().ok(); }));
}

TEST(PioneerBaseTest, SilentPeerFailsConnectNamingTheDevice) {
  FakeArcosOptions silent;
  silent.silent = true;
  auto peer = StartPeer(silent);
  ASSERT_NE(peer, nullptr);
  PioneerOptions options;
  options.sync_timeout = absl::Milliseconds(200);
  options.sync_attempts = 2;
  auto base = PioneerBase::Connect(peer->device_path(), options);
  ASSERT_FALSE(base.ok());
  EXPECT_EQ(base.status().code(), absl::StatusCode::kUnavailable) << base.status();
  EXPECT_NE(base.status().message().find(peer->device_path()), std::string::npos) << base.status();
  EXPECT_NE(base.status().message().find("SYNC0"), std::string::npos) << base.status();
  EXPECT_NE(base.status().message().find("2 attempts"), std::string::npos) << base.status();
  // It tried SYNC0 twice and never sent OPEN to a robot it could not see.
  EXPECT_TRUE(Eventually([&] { return peer->Count("SYNC0") == 2; }));
  EXPECT_EQ(peer->Count("OPEN"), 0);
  EXPECT_EQ(peer->Count("CLOSE"), 0);
}

TEST(PioneerBaseTest, BadOptionsAreRejected) {
  PioneerOptions options;
  options.pulse_interval = absl::Seconds(3);  // longer than the robot's watchdog
  EXPECT_EQ(PioneerBase::Connect("/dev/null", options).status().code(),
            absl::StatusCode::kInvalidArgument);
  options = PioneerOptions();
  options.max_linear = -1;
  EXPECT_EQ(PioneerBase::Connect("/dev/null", options).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(PioneerBase::Connect("/dev/ttyWAYMARK_missing").status().code(),
            absl::StatusCode::kNotFound);
}

TEST(PioneerBaseTest, DestructorStopsAndClosesTheRobot) {
  auto peer = StartPeer();
  ASSERT_NE(peer, nullptr);
  auto base = PioneerBase::Connect(peer->device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  ASSERT_TRUE((*base)->SetVelocity(0.2, 0.3).ok());
  base->reset();
  ASSERT_TRUE(peer->WaitFor(
      [](const Commands& c) { return !c.empty() && c.back().name == "CLOSE"; }, kPatience));
  const Commands log = peer->commands();
  ASSERT_GE(log.size(), 3u);
  const auto& vel = log[log.size() - 3];
  const auto& rvel = log[log.size() - 2];
  EXPECT_EQ(vel.name, "VEL");
  EXPECT_EQ(vel.arg, 0);
  EXPECT_EQ(rvel.name, "RVEL");
  EXPECT_EQ(rvel.arg, 0);
  EXPECT_FALSE(peer->is_open());
  // Nothing after CLOSE (a PULSE would read as SYNC0 to a closed robot).
  absl::SleepFor(absl::Milliseconds(700));
  EXPECT_EQ(peer->commands().size(), log.size());
}

}  // namespace
}  // namespace waymark::adapters
