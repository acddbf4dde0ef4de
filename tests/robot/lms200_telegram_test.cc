// SICK LMS200 telegram framing and CRC against the golden byte vectors of issue 5.

#include "client/devices/lms200_telegram.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace waymark::adapters {
namespace {

using Bytes = std::vector<std::uint8_t>;

TEST(Lms200TelegramTest, GoldenVectors) {
  EXPECT_EQ(*EncodeLms200Telegram({0x20, 0x24}),
            (Bytes{0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08}));  // continuous output
  EXPECT_EQ(*EncodeLms200Telegram({0x20, 0x25}),
            (Bytes{0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08}));  // stop
  EXPECT_EQ(*EncodeLms200Telegram({0x20, 0x40}),
            (Bytes{0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08}));  // 38400 baud
  // Variants: 180 degrees at 0.5 and at 1 degree.
  const Bytes half = *EncodeLms200Telegram({0x3B, 0xB4, 0x00, 0x32, 0x00});
  EXPECT_EQ(Bytes(half.end() - 2, half.end()), (Bytes{0x3B, 0x1F}));
  const Bytes one = *EncodeLms200Telegram({0x3B, 0xB4, 0x00, 0x64, 0x00});
  EXPECT_EQ(Bytes(one.end() - 2, one.end()), (Bytes{0x97, 0x49}));
  EXPECT_EQ(Bytes(one.begin(), one.begin() + 4), (Bytes{0x02, 0x00, 0x05, 0x00}));
}

TEST(Lms200TelegramTest, CrcOfATelegramWithItsCrcFollowsTheAlgorithm) {
  const Bytes t = *EncodeLms200Telegram({0x20, 0x24});
  EXPECT_EQ(Lms200Crc(t.data(), t.size() - 2), 0x0834);
  EXPECT_EQ(Lms200Crc(nullptr, 0), 0);
}

TEST(Lms200TelegramTest, RefusesEmptyAndOversizedBodies) {
  EXPECT_FALSE(EncodeLms200Telegram({}).ok());
  EXPECT_FALSE(EncodeLms200Telegram(Bytes(813, 0)).ok());
  EXPECT_TRUE(EncodeLms200Telegram(Bytes(812, 0)).ok());
}

}  // namespace
}  // namespace waymark::adapters

namespace waymark::adapters {
namespace {

Lms200Telegram ScanReply(int units, const std::vector<int>& values) {
  Lms200Telegram t;
  t.command = 0xB0;
  const int word = static_cast<int>(values.size()) | (units << 14);
  t.data = {static_cast<std::uint8_t>(word & 0xFF), static_cast<std::uint8_t>(word >> 8)};
  for (int v : values) {
    t.data.push_back(static_cast<std::uint8_t>(v & 0xFF));
    t.data.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  return t;
}

TEST(Lms200ScanTest, DecodesMillimetresAndCentimetresAndMasksFlagBits) {
  auto mm = DecodeLms200Scan(ScanReply(1, {1234, 8183, 0x2000 | 500}));
  ASSERT_TRUE(mm.ok()) << mm.status();
  ASSERT_EQ(mm->ranges_m.size(), 3u);
  EXPECT_FLOAT_EQ(mm->ranges_m[0], 1.234f);
  EXPECT_FLOAT_EQ(mm->ranges_m[1], 8.183f);
  EXPECT_FLOAT_EQ(mm->ranges_m[2], 0.5f);  // a flag bit above the range bits is dropped
  auto cm = DecodeLms200Scan(ScanReply(0, {250}));
  ASSERT_TRUE(cm.ok());
  EXPECT_FLOAT_EQ(cm->ranges_m[0], 2.5f);
  Lms200Telegram short_reply = ScanReply(1, {1, 2, 3});
  short_reply.data.resize(5);
  EXPECT_FALSE(DecodeLms200Scan(short_reply).ok());
  EXPECT_FALSE(DecodeLms200Scan(ScanReply(2, {1})).ok());
  Lms200Telegram other = ScanReply(1, {1});
  other.command = 0xA0;
  EXPECT_FALSE(DecodeLms200Scan(other).ok());
}

TEST(Lms200ParserTest, SkipsAcksAndGarbageDropsBadCrcsAndSurvivesRandomBytes) {
  Bytes reply_body = {0xB0, 0x02, 0x40, 0xE8, 0x03, 0xD0, 0x07};  // 2 values in mm: 1 m, 2 m
  Bytes reply = *EncodeLms200Telegram(reply_body, 0x80);
  Bytes corrupt = reply;
  corrupt[6] ^= 0xFF;
  Bytes stream = {lms200::kAck, 0x55, lms200::kNak};
  stream.insert(stream.end(), corrupt.begin(), corrupt.end());
  stream.insert(stream.end(), reply.begin(), reply.end());
  Lms200Parser parser;
  std::vector<Lms200Telegram> got;
  for (std::uint8_t b : stream) {
    parser.Feed(&b, 1);
    while (auto t = parser.Next()) got.push_back(*t);
  }
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].address, 0x80);
  auto scan = DecodeLms200Scan(got[0]);
  ASSERT_TRUE(scan.ok()) << scan.status();
  EXPECT_EQ(scan->ranges_m, (std::vector<float>{1.0f, 2.0f}));
  EXPECT_EQ(parser.naks(), 1u);
  EXPECT_GE(parser.bad_crcs(), 1u);

  std::mt19937 rng(11);
  std::uniform_int_distribution<int> byte(0, 255);
  int found = 0;
  for (int round = 0; round < 2000; ++round) {
    Bytes noise(1 + byte(rng) % 32);
    for (auto& b : noise) b = static_cast<std::uint8_t>(byte(rng));
    parser.Feed(noise.data(), noise.size());
    parser.Feed(reply.data(), reply.size());
    while (auto t = parser.Next()) found += t->command == 0xB0;
  }
  EXPECT_GT(found, 1000);  // a noise STX with a plausible length can swallow a reply
}

}  // namespace
}  // namespace waymark::adapters
