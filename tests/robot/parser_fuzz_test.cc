// Both serial parsers and their decoders on hostile input: random payloads of random length must
// give a value or INVALID_ARGUMENT, never a crash or an out-of-range read (run under ASan to see
// the latter); and a recorded-style SIP stream, chopped into arbitrary reads with noise between
// packets, must come out as the trajectory that produced it.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "client/devices/lms200_telegram.h"
#include "client/devices/p2os_packet.h"
#include "client/devices/p2os_sip.h"

namespace waymark::adapters {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes RandomBytes(std::mt19937& rng, int max_size) {
  std::uniform_int_distribution<int> size(0, max_size), byte(0, 255);
  Bytes out(size(rng));
  for (auto& b : out) b = static_cast<std::uint8_t>(byte(rng));
  return out;
}

TEST(ParserFuzzTest, SipDecoderTakesAnyPayload) {
  std::mt19937 rng(3);
  int decoded = 0;
  for (int i = 0; i < 20000; ++i) {
    P2osPacket packet;
    packet.id = (i % 2) ? 0x32 : 0x33;
    packet.payload = RandomBytes(rng, 80);
    auto sip = DecodeStandardSip(packet);
    if (sip.ok()) {
      ++decoded;
      EXPECT_LE(sip->sonars.size(), 255u);
    } else {
      EXPECT_EQ(sip.status().code(), absl::StatusCode::kInvalidArgument);
    }
  }
  EXPECT_GT(decoded, 0);  // long enough random payloads do decode: the test exercises both paths
}

TEST(ParserFuzzTest, ScanDecoderTakesAnyTelegram) {
  std::mt19937 rng(5);
  int decoded = 0;
  for (int i = 0; i < 20000; ++i) {
    Lms200Telegram telegram;
    telegram.address = 0x80;
    telegram.command = 0xB0;
    telegram.data = RandomBytes(rng, 64);
    if (i % 3 == 0 && telegram.data.size() >= 2) {
      // A count word that fits what follows, so the value path runs too.
      const int values = static_cast<int>((telegram.data.size() - 2) / 2);
      telegram.data[0] = static_cast<std::uint8_t>(values & 0xFF);
      telegram.data[1] = static_cast<std::uint8_t>((values >> 8) | 0x40);
    }
    auto scan = DecodeLms200Scan(telegram);
    if (scan.ok()) {
      ++decoded;
      for (float r : scan->ranges_m) EXPECT_TRUE(std::isfinite(r) && r >= 0);
    } else {
      EXPECT_EQ(scan.status().code(), absl::StatusCode::kInvalidArgument);
    }
  }
  EXPECT_GT(decoded, 0);
}

TEST(ParserFuzzTest, BothParsersSurviveLongRandomStreamsInRandomChunks) {
  std::mt19937 rng(9);
  P2osParser p2os;
  Lms200Parser lms;
  std::uint64_t packets = 0;
  for (int i = 0; i < 5000; ++i) {
    const Bytes chunk = RandomBytes(rng, 300);
    p2os.Feed(chunk.data(), chunk.size());
    lms.Feed(chunk.data(), chunk.size());
    while (auto p = p2os.Next()) {
      ++packets;
      DecodeStandardSip(*p).IgnoreError();
    }
    while (auto t = lms.Next()) {
      ++packets;
      DecodeLms200Scan(*t).IgnoreError();
    }
  }
  // Whatever the noise left half-parsed, real packets come through again: a stray header can
  // hold back at most 200 (P2OS) or 816 (LMS200) bytes.
  const Bytes pulse = EncodeP2osCommand(p2os::kPulse);
  const Bytes reply = *EncodeLms200Telegram({0xB0, 0x01, 0x40, 0xE8, 0x03}, 0x80);
  int pulses = 0, replies = 0;
  for (int i = 0; i < 60; ++i) {
    p2os.Feed(pulse.data(), pulse.size());
    lms.Feed(reply.data(), reply.size());
    while (auto p = p2os.Next()) pulses += p->id == p2os::kPulse;
    while (auto t = lms.Next()) replies += t->command == 0xB0 && t->data.size() == 4;
  }
  EXPECT_GT(pulses, 20);
  EXPECT_GT(replies, 20);
  RecordProperty("random_packets_passing_checksums", static_cast<int>(packets));
}

// 200 SIPs (20 s at 10 Hz) of a robot driving a 3 m radius circle across the 15-bit wrap of x,
// with random garbage between packets and reads of random length: the unwrapped odometry must
// be the trajectory that was encoded, to the millimetre.
TEST(ParserFuzzTest, RecordedStyleSipStreamComesOutAsItsTrajectory) {
  std::mt19937 rng(21);
  std::vector<SipOdometry::Pose> truth;
  Bytes stream;
  for (int k = 0; k < 200; ++k) {
    const double a = 0.05 * k;
    const double x_mm = 16000 + 3000 * std::sin(a);  // crosses 16383 -> wraps
    const double y_mm = -3000 + 3000 * std::cos(a);
    StandardSip sip;
    sip.moving = true;
    const long long xi = std::llround(x_mm), yi = std::llround(y_mm);
    sip.x_raw = static_cast<int>(((xi % 32768) + 32768) % 32768);
    sip.y_raw = static_cast<int>(((yi % 32768) + 32768) % 32768);
    sip.theta_raw =
        static_cast<int>(std::llround(std::fmod(a, 2 * M_PI) * 4096 / (2 * M_PI))) % 4096;
    sip.motors_enabled = true;
    P2osPacket packet{static_cast<std::uint8_t>(0x33), EncodeStandardSipPayload(sip)};
    auto bytes = EncodeP2osPacket(packet.id, packet.payload);
    ASSERT_TRUE(bytes.ok());
    if (k % 7 == 3) {
      const Bytes noise = RandomBytes(rng, 5);
      stream.insert(stream.end(), noise.begin(), noise.end());
    }
    stream.insert(stream.end(), bytes->begin(), bytes->end());
    truth.push_back({xi / 1000.0, yi / 1000.0, 0});
  }
  P2osParser parser;
  SipOdometry odometry;
  std::vector<SipOdometry::Pose> got;
  std::uniform_int_distribution<int> read_size(1, 40);
  for (size_t at = 0; at < stream.size();) {
    const size_t n = std::min<size_t>(read_size(rng), stream.size() - at);
    parser.Feed(stream.data() + at, n);
    at += n;
    while (auto p = parser.Next()) {
      auto sip = DecodeStandardSip(*p);
      if (sip.ok()) got.push_back(odometry.Update(*sip));
    }
  }
  // Noise may cost a packet now and then (a stray header swallowing one); most come through,
  // and every one that does is exactly on the trajectory relative to the first.
  ASSERT_GT(got.size(), 180u);
  size_t t = 0;
  for (const auto& pose : got) {
    // Find this pose in the truth (packets are in order; lost ones are skipped).
    // The first packet has no noise before it, so got[0] is truth[0]; odometry is relative to it.
    const double dx = pose.x - got[0].x, dy = pose.y - got[0].y;
    while (t < truth.size() && (std::abs((truth[t].x - truth[0].x) - dx) > 1e-3 ||
                                std::abs((truth[t].y - truth[0].y) - dy) > 1e-3)) {
      ++t;
    }
    ASSERT_LT(t, truth.size()) << "pose (" << pose.x << ", " << pose.y << ") is not on the path";
  }
}

}  // namespace
}  // namespace waymark::adapters
