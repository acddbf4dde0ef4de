#include "client/devices/lms200_scanner.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "tests/robot/eventually.h"
#include "tests/robot/fake_lms200_peer.h"
#include "tests/robot/pty_pair.h"

namespace waymark::adapters {
namespace {

using ::testing::ElementsAre;
using testing::FakeLms200Options;
using testing::FakeLms200Peer;
using testing::FakeLms200RateEvent;
using ::testing::HasSubstr;

using Bytes = std::vector<std::uint8_t>;

// The golden telegrams.
const Bytes kStopTelegram = {0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08};
const Bytes kStartTelegram = {0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08};
const Bytes k38400Telegram = {0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08};

// Short timeouts so probing absent rates stays quick; still generous for a loaded machine.
Lms200Options TestOptions() {
  Lms200Options options;
  options.reply_timeout = absl::Milliseconds(300);
  options.retries = 2;
  options.baud_switch_pause = absl::Milliseconds(20);
  options.scan_timeout = absl::Seconds(2);
  return options;
}

std::unique_ptr<FakeLms200Peer> StartFake(FakeLms200Options options = {}) {
  auto fake = FakeLms200Peer::Start(std::move(options));
  EXPECT_TRUE(fake.ok()) << fake.status();
  return fake.ok() ? std::move(*fake) : nullptr;
}

int IndexOf(const std::vector<FakeLms200RateEvent>& events, bool laser, int baud, int from = 0) {
  for (int i = from; i < static_cast<int>(events.size()); ++i) {
    if (events[i].laser == laser && events[i].baud == baud) return i;
  }
  return -1;
}

TEST(Lms200ScannerTest, SwitchesTheLaserFirstThenTheHost) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  EXPECT_EQ((*scanner)->baud(), 38400);
  EXPECT_EQ(fake->baud(), 38400);
  EXPECT_TRUE(fake->streaming());

  const auto heard = fake->heard();
  ASSERT_EQ(heard.size(), 4u);
  EXPECT_EQ(heard[0].telegram, kStopTelegram);
  EXPECT_EQ(heard[0].baud, 9600);
  EXPECT_THAT(fake->commands()[1], ElementsAre(0x3B, 0xB4, 0x00, 0x64, 0x00));
  EXPECT_EQ(heard[1].baud, 9600);
  EXPECT_EQ(heard[2].telegram, k38400Telegram);
  EXPECT_EQ(heard[2].baud, 9600);
  EXPECT_EQ(heard[3].telegram, kStartTelegram);
  EXPECT_EQ(heard[3].baud, 38400);

  // Once the host opened at 9600, the laser moved to 38400 before the host did.
  const auto events = fake->rate_events();
  const int host_opened = IndexOf(events, false, 9600);
  ASSERT_GE(host_opened, 0);
  const int laser_switched = IndexOf(events, true, 38400, host_opened);
  const int host_switched = IndexOf(events, false, 38400, host_opened);
  ASSERT_GE(laser_switched, 0);
  ASSERT_GE(host_switched, 0);
  EXPECT_LT(laser_switched, host_switched);
  EXPECT_EQ(fake->ignored_bytes(), 0u);
}

TEST(Lms200ScannerTest, FindsASensorLeftStreamingAtTheTargetRate) {
  FakeLms200Options fake_options;
  fake_options.baud = 38400;
  fake_options.streaming = true;
  auto fake = StartFake(fake_options);
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  EXPECT_EQ((*scanner)->baud(), 38400);
  // The stop sent at 9600 fell on deaf ears; the one at 38400 was understood.
  EXPECT_GT(fake->ignored_bytes(), 0u);
  const auto commands = fake->commands();
  ASSERT_EQ(commands.size(), 3u);
  EXPECT_THAT(commands[0], ElementsAre(0x20, 0x25));
  EXPECT_THAT(commands[1], ElementsAre(0x3B, 0xB4, 0x00, 0x64, 0x00));
  EXPECT_THAT(commands[2], ElementsAre(0x20, 0x24));  // no rate change needed
  auto reading = (*scanner)->Read();
  ASSERT_TRUE(reading.ok()) << reading.status();
  EXPECT_EQ(reading->ranges.size(), 181u);
}

TEST(Lms200ScannerTest, FindsASensorAtAnotherRateAndMovesIt) {
  FakeLms200Options fake_options;
  fake_options.baud = 19200;
  auto fake = StartFake(fake_options);
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  EXPECT_EQ(fake->baud(), 38400);
  const auto heard = fake->heard();
  ASSERT_EQ(heard.size(), 4u);
  EXPECT_EQ(heard[0].telegram, kStopTelegram);
  EXPECT_EQ(heard[0].baud, 19200);
  EXPECT_EQ(heard[2].telegram, k38400Telegram);
  EXPECT_EQ(heard[2].baud, 19200);
  EXPECT_EQ(heard[3].telegram, kStartTelegram);
  EXPECT_EQ(heard[3].baud, 38400);
}

TEST(Lms200ScannerTest, StaysAt9600WhenAskedTo) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  Lms200Options options = TestOptions();
  options.baud = 9600;
  auto scanner = Lms200Scanner::Connect(fake->device_path(), options);
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  EXPECT_EQ(fake->baud(), 9600);
  EXPECT_THAT(fake->commands().back(), ElementsAre(0x20, 0x24));
  EXPECT_EQ(fake->commands().size(), 3u);
}

TEST(Lms200ScannerTest, LayoutMatchesTheVariant) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  const LaserLayout layout = (*scanner)->layout();
  EXPECT_EQ(layout.beam_count, 181u);
  EXPECT_DOUBLE_EQ(layout.angle_min, -M_PI / 2);
  EXPECT_DOUBLE_EQ(layout.angle_increment, M_PI / 180);
  EXPECT_DOUBLE_EQ(layout.no_return_range, 8.183);
  EXPECT_DOUBLE_EQ(layout.mount.x, 0.16);
  EXPECT_DOUBLE_EQ(layout.mount.y, 0.0);
  EXPECT_DOUBLE_EQ(layout.mount.theta, 0.0);
}

TEST(Lms200ScannerTest, HalfDegreeGives361Beams) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  Lms200Options options = TestOptions();
  options.half_degree = true;
  auto scanner = Lms200Scanner::Connect(fake->device_path(), options);
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  EXPECT_THAT(fake->commands()[1], ElementsAre(0x3B, 0xB4, 0x00, 0x32, 0x00));
  EXPECT_EQ(fake->beam_count(), 361);
  const LaserLayout layout = (*scanner)->layout();
  EXPECT_EQ(layout.beam_count, 361u);
  EXPECT_DOUBLE_EQ(layout.angle_min, -M_PI / 2);
  EXPECT_DOUBLE_EQ(layout.angle_min + 360 * layout.angle_increment, M_PI / 2);
  auto reading = (*scanner)->Read();
  ASSERT_TRUE(reading.ok()) << reading.status();
  EXPECT_EQ(reading->ranges.size(), 361u);
}

TEST(Lms200ScannerTest, ScansDecodeToTheSensorsRangesInMetres) {
  FakeLms200Options fake_options;
  fake_options.range_mm = [](int beam, int) { return static_cast<std::uint16_t>(500 + 7 * beam); };
  auto fake = StartFake(fake_options);
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  double last_stamp = 0;
  for (int n = 0; n < 3; ++n) {
    auto reading = (*scanner)->Read();
    ASSERT_TRUE(reading.ok()) << reading.status();
    ASSERT_EQ(reading->ranges.size(), 181u);
    for (int i = 0; i < 181; ++i) {
      EXPECT_NEAR(reading->ranges[i], (500 + 7 * i) / 1000.0, 1e-6) << "beam " << i;
    }
    EXPECT_GT(reading->stamp, last_stamp);
    EXPECT_NEAR(reading->stamp, absl::ToDoubleSeconds(absl::Now() - absl::UnixEpoch()), 60);
    last_stamp = reading->stamp;
  }
  EXPECT_EQ((*scanner)->stats().scans, 3u);
}

TEST(Lms200ScannerTest, NoReturnCodesReadAtOrAboveTheNoReturnRange) {
  FakeLms200Options fake_options;
  fake_options.range_mm = [](int beam, int) {
    return static_cast<std::uint16_t>(beam == 0 ? 8191 : beam == 1 ? 8183 : 2000);
  };
  auto fake = StartFake(fake_options);
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  auto reading = (*scanner)->Read();
  ASSERT_TRUE(reading.ok()) << reading.status();
  const double no_return = (*scanner)->layout().no_return_range;
  EXPECT_GE(reading->ranges[0], no_return - 1e-6);
  EXPECT_GE(reading->ranges[1], no_return - 1e-6);
  EXPECT_LT(reading->ranges[2], no_return);
}

TEST(Lms200ScannerTest, BadBytesAreCountedAndSurvived) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  ASSERT_TRUE((*scanner)->Read().ok());
  const Lms200Stats before = (*scanner)->stats();

  fake->SendGarbage({0xFF, 0x00, 0x13, 0x99, 0x42});
  fake->SendBadCrcScan();
  fake->SendNak();
  fake->SendScanOfSize(100);
  // A valid telegram that is no scan (a status reply, say).
  auto status_reply = EncodeLms200Telegram({0xB1, 0x00}, 0x80);
  ASSERT_TRUE(status_reply.ok());
  fake->SendGarbage(*status_reply);

  // Until every injected fault was counted; the deadline only turns a hang into a failure.
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  Lms200Stats after = before;
  while (absl::Now() < deadline) {
    auto reading = (*scanner)->Read();
    ASSERT_TRUE(reading.ok()) << reading.status();
    ASSERT_EQ(reading->ranges.size(), 181u);
    EXPECT_NEAR(reading->ranges[10], 1.010, 1e-6);
    after = (*scanner)->stats();
    if (after.bad_crcs > before.bad_crcs && after.naks > before.naks &&
        after.wrong_size_scans > before.wrong_size_scans &&
        after.other_telegrams > before.other_telegrams &&
        after.skipped_bytes >= before.skipped_bytes + 5) {
      break;
    }
  }
  EXPECT_GT(after.bad_crcs, before.bad_crcs);
  EXPECT_GT(after.naks, before.naks);
  EXPECT_EQ(after.wrong_size_scans, before.wrong_size_scans + 1);
  EXPECT_EQ(after.other_telegrams, before.other_telegrams + 1);
  EXPECT_GE(after.skipped_bytes, before.skipped_bytes + 5);
  // And scans keep coming.
  ASSERT_TRUE((*scanner)->Read().ok());
}

TEST(Lms200ScannerTest, RejectedCommandsAreResent) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  fake->NakNextCommands(1);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  EXPECT_EQ((*scanner)->stats().naks, 1u);
  const auto commands = fake->commands();
  ASSERT_GE(commands.size(), 2u);
  EXPECT_THAT(commands[0], ElementsAre(0x20, 0x25));
  EXPECT_THAT(commands[1], ElementsAre(0x20, 0x25));
}

TEST(Lms200ScannerTest, UnpluggedSensorIsUnavailable) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  ASSERT_TRUE((*scanner)->Read().ok());
  fake->Hangup();
  absl::Status status;
  for (int i = 0; i < 1000 && status.ok(); ++i) status = (*scanner)->Read().status();
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_THAT(std::string(status.message()), HasSubstr(fake->device_path()));
}

TEST(Lms200ScannerTest, SilentSensorIsUnavailableAfterTheScanTimeout) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  Lms200Options options = TestOptions();
  options.scan_timeout = absl::Milliseconds(300);
  auto scanner = Lms200Scanner::Connect(fake->device_path(), options);
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  ASSERT_TRUE((*scanner)->Read().ok());
  fake->Mute();
  absl::Status status;
  for (int i = 0; i < 1000 && status.ok(); ++i) status = (*scanner)->Read().status();
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_THAT(std::string(status.message()), HasSubstr("no scan"));
}

TEST(Lms200ScannerTest, SilentPeerFailsToConnectNamingTheDevice) {
  auto pty = testing::PtyPair::Open();
  ASSERT_TRUE(pty.ok()) << pty.status();
  Lms200Options options = TestOptions();
  options.reply_timeout = absl::Milliseconds(100);
  options.retries = 1;
  auto scanner = Lms200Scanner::Connect(pty->device_path(), options);
  ASSERT_FALSE(scanner.ok());
  EXPECT_EQ(scanner.status().code(), absl::StatusCode::kUnavailable) << scanner.status();
  const std::string message(scanner.status().message());
  EXPECT_THAT(message, HasSubstr(pty->device_path()));
  EXPECT_THAT(message, HasSubstr("9600"));
  EXPECT_THAT(message, HasSubstr("500000"));
  EXPECT_THAT(message, HasSubstr("powered"));
}

TEST(Lms200ScannerTest, BadOptionsAreRejected) {
  Lms200Options options;
  options.baud = 57600;  // termios has it, the LMS200 does not
  EXPECT_EQ(Lms200Scanner::Connect("/dev/null", options).status().code(),
            absl::StatusCode::kInvalidArgument);
  options = Lms200Options();
  options.retries = 0;
  EXPECT_EQ(Lms200Scanner::Connect("/dev/null", options).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Lms200Scanner::Connect("/dev/ttyWAYMARK_missing").status().code(),
            absl::StatusCode::kNotFound);
}

TEST(Lms200ScannerTest, DestructorStopsTheOutput) {
  auto fake = StartFake();
  ASSERT_NE(fake, nullptr);
  {
    auto scanner = Lms200Scanner::Connect(fake->device_path(), TestOptions());
    ASSERT_TRUE(scanner.ok()) << scanner.status();
    ASSERT_TRUE((*scanner)->Read().ok());
    EXPECT_TRUE(fake->streaming());
  }
  EXPECT_TRUE(testing::Eventually([&] { return !fake->streaming(); }));
  const auto heard = fake->heard();
  ASSERT_FALSE(heard.empty());
  EXPECT_EQ(heard.back().telegram, kStopTelegram);
  EXPECT_EQ(heard.back().baud, 38400);
}

}  // namespace
}  // namespace waymark::adapters
