// SICK LMS200 telegram framing and CRC against the golden byte vectors of issue 5.

#include "client/adapters/lms200_telegram.h"

#include <vector>

#include <gtest/gtest.h>

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
