// Unplugging and replugging a cable: the reconnecting wrappers drop a device whose link failed,
// report UNAVAILABLE while it is away, and reconnect through the real drivers once a (new) fake
// peer answers on the device path the factory names.
#include "client/devices/reconnecting_devices.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <mutex>

#include "client/devices/lms200_scanner.h"
#include "client/devices/pioneer_base.h"
#include "tests/robot/eventually.h"
#include "tests/robot/fake_arcos_peer.h"
#include "tests/robot/fake_lms200_peer.h"

namespace waymark::adapters {
namespace {

using testing::Eventually;
using testing::FakeArcosPeer;
using testing::FakeLms200Options;
using testing::FakeLms200Peer;
using ::testing::HasSubstr;
using testing::PtyPair;

// The device path the factory connects to; a test "replugs" by pointing it at a new fake.
class Socket {
 public:
  void Plug(std::string path) {
    std::lock_guard<std::mutex> lock(mutex_);
    path_ = std::move(path);
  }
  std::string path() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return path_;
  }

 private:
  mutable std::mutex mutex_;
  std::string path_;
};

std::unique_ptr<FakeArcosPeer> NewRobot() {
  auto pty = PtyPair::Open();
  EXPECT_TRUE(pty.ok()) << pty.status();
  return std::make_unique<FakeArcosPeer>(*std::move(pty));
}

Lms200Options FastLaserOptions(bool half_degree = false) {
  Lms200Options options;
  options.reply_timeout = absl::Milliseconds(200);
  options.retries = 1;
  options.baud_switch_pause = absl::Milliseconds(20);
  options.scan_timeout = absl::Milliseconds(500);
  options.half_degree = half_degree;
  return options;
}

TEST(ReconnectingDevicesTest, BaseComesBackAfterTheCableIsReplugged) {
  Socket socket;
  auto robot = NewRobot();
  socket.Plug(robot->device_path());
  int connects = 0;
  auto base = ReconnectingBase::Create(
      [&]() -> absl::StatusOr<std::unique_ptr<MobileBase>> {
        ++connects;
        PioneerOptions options;
        options.sync_attempts = 1;
        auto pioneer = PioneerBase::Connect(socket.path(), options);
        if (!pioneer.ok()) return pioneer.status();
        return std::unique_ptr<MobileBase>(*std::move(pioneer));
      },
      absl::Milliseconds(50));
  ASSERT_TRUE(base.ok()) << base.status();
  EXPECT_DOUBLE_EQ((*base)->max_linear(), PioneerOptions().max_linear);
  ASSERT_TRUE(Eventually([&] { return (*base)->Read().ok(); }));

  robot->Hangup();  // cable out
  ASSERT_TRUE(Eventually([&] { return !(*base)->Read().ok(); }));
  auto away = (*base)->Read();
  EXPECT_EQ(away.status().code(), absl::StatusCode::kUnavailable) << away.status();
  EXPECT_EQ((*base)->SetVelocity(0.1, 0).code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ((*base)->reconnects(), 0);

  auto replugged = NewRobot();  // cable in (a new pty: a USB adapter may come back renamed too)
  socket.Plug(replugged->device_path());
  ASSERT_TRUE(Eventually([&] { return (*base)->Read().ok(); }));
  EXPECT_EQ((*base)->reconnects(), 1);
  EXPECT_GE(connects, 2);
  ASSERT_TRUE((*base)->SetVelocity(0.2, 0).ok());
  EXPECT_TRUE(replugged->WaitFor(
      [](const std::vector<FakeArcosPeer::Command>& log) {
        for (const auto& c : log) {
          if (c.name == "VEL" && c.arg == 200) return true;
        }
        return false;
      },
      absl::Seconds(5)));
}

TEST(ReconnectingDevicesTest, RetriesAtMostOncePerInterval) {
  int connects = 0;
  bool fail = false;
  class Dummy : public MobileBase {
   public:
    explicit Dummy(bool* fail) : fail_(fail) {}
    absl::Status SetVelocity(double, double) override { return absl::OkStatus(); }
    absl::Status Stop() override { return absl::OkStatus(); }
    absl::StatusOr<BaseState> Read() override {
      if (*fail_) return absl::UnavailableError("/dev/ttyS0 hung up");
      return BaseState{};
    }
    double max_linear() const override { return 1; }
    double max_angular() const override { return 1; }

   private:
    bool* fail_;
  };
  auto base = ReconnectingBase::Create(
      [&]() -> absl::StatusOr<std::unique_ptr<MobileBase>> {
        ++connects;
        if (connects > 1) return absl::NotFoundError("no /dev/ttyS0");
        return std::unique_ptr<MobileBase>(std::make_unique<Dummy>(&fail));
      },
      absl::Hours(1));
  ASSERT_TRUE(base.ok());
  fail = true;
  EXPECT_EQ((*base)->Read().status().code(), absl::StatusCode::kUnavailable);
  for (int i = 0; i < 100; ++i) {
    auto r = (*base)->Read();
    EXPECT_EQ(r.status().code(), absl::StatusCode::kUnavailable);  // not NOT_FOUND: it is away
    EXPECT_THAT(std::string(r.status().message()), HasSubstr("/dev/ttyS0"));
  }
  EXPECT_EQ(connects, 1);  // the hour has not passed
}

TEST(ReconnectingDevicesTest, LaserComesBackAndMustKeepItsLayout) {
  Socket socket;
  bool half_degree = false;
  FakeLms200Options fake_options;
  fake_options.scan_period = absl::Milliseconds(50);
  auto fake = FakeLms200Peer::Start(fake_options);
  ASSERT_TRUE(fake.ok()) << fake.status();
  socket.Plug((*fake)->device_path());
  auto laser = ReconnectingLaser::Create(
      [&]() -> absl::StatusOr<std::unique_ptr<LaserScanner>> {
        auto scanner = Lms200Scanner::Connect(socket.path(), FastLaserOptions(half_degree));
        if (!scanner.ok()) return scanner.status();
        return std::unique_ptr<LaserScanner>(*std::move(scanner));
      },
      absl::Milliseconds(50));
  ASSERT_TRUE(laser.ok()) << laser.status();
  EXPECT_EQ((*laser)->layout().beam_count, 181u);
  ASSERT_TRUE((*laser)->Read().ok());

  (*fake)->Hangup();
  ASSERT_TRUE(Eventually([&] { return !(*laser)->Read().ok(); }));
  auto again = FakeLms200Peer::Start(fake_options);
  ASSERT_TRUE(again.ok());
  socket.Plug((*again)->device_path());
  ASSERT_TRUE(Eventually([&] { return (*laser)->Read().ok(); }, absl::Seconds(10)));
  EXPECT_EQ((*laser)->reconnects(), 1);

  // Comes back configured for 361 beams: refused, the session expects 181.
  (*again)->Hangup();
  ASSERT_TRUE(Eventually([&] { return !(*laser)->Read().ok(); }));
  FakeLms200Options half = fake_options;
  half.half_degree = true;
  auto third = FakeLms200Peer::Start(half);
  ASSERT_TRUE(third.ok());
  half_degree = true;
  socket.Plug((*third)->device_path());
  absl::Status refused;
  ASSERT_TRUE(Eventually(
      [&] {
        refused = (*laser)->Read().status();
        return refused.code() == absl::StatusCode::kFailedPrecondition;
      },
      absl::Seconds(10)))
      << refused;
  EXPECT_THAT(std::string(refused.message()), HasSubstr("361 beams"));
  EXPECT_EQ((*laser)->layout().beam_count, 181u);
}

}  // namespace
}  // namespace waymark::adapters
