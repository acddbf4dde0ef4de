// ARCOS / P2OS framing against the golden byte vectors of issue 5, round trips through the
// parser, and random bytes that must never crash it.

#include "client/devices/p2os_packet.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace waymark::adapters {
namespace {

using Bytes = std::vector<std::uint8_t>;

TEST(P2osPacketTest, GoldenVectors) {
  EXPECT_EQ(EncodeP2osCommand(p2os::kSync0), (Bytes{0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00}));
  EXPECT_EQ(EncodeP2osCommand(p2os::kPulse), (Bytes{0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00}));
  EXPECT_EQ(EncodeP2osCommand(p2os::kSync1), (Bytes{0xFA, 0xFB, 0x03, 0x01, 0x00, 0x01}));
  EXPECT_EQ(EncodeP2osCommand(p2os::kOpen), (Bytes{0xFA, 0xFB, 0x03, 0x01, 0x00, 0x01}));
  EXPECT_EQ(EncodeP2osCommand(p2os::kSync2), (Bytes{0xFA, 0xFB, 0x03, 0x02, 0x00, 0x02}));
  EXPECT_EQ(EncodeP2osCommand(p2os::kClose), (Bytes{0xFA, 0xFB, 0x03, 0x02, 0x00, 0x02}));
  EXPECT_EQ(*EncodeP2osCommand(p2os::kEnable, 1),
            (Bytes{0xFA, 0xFB, 0x06, 0x04, 0x3B, 0x01, 0x00, 0x05, 0x3B}));
  EXPECT_EQ(*EncodeP2osCommand(p2os::kVel, 200),
            (Bytes{0xFA, 0xFB, 0x06, 0x0B, 0x3B, 0xC8, 0x00, 0xD3, 0x3B}));
  EXPECT_EQ(*EncodeP2osCommand(p2os::kRotVel, -30),
            (Bytes{0xFA, 0xFB, 0x06, 0x15, 0x1B, 0x1E, 0x00, 0x33, 0x1B}));
}

TEST(P2osPacketTest, ChecksumXorsTheOddLastByte) {
  const Bytes odd = {0x12, 0x34, 0x56};
  EXPECT_EQ(P2osChecksum(odd.data(), odd.size()), 0x1234 ^ 0x56);
  const Bytes overflow = {0xFF, 0xFF, 0x00, 0x02};
  EXPECT_EQ(P2osChecksum(overflow.data(), overflow.size()), 0x0001);  // masked to 16 bits
}

TEST(P2osPacketTest, RefusesWhatTheProtocolCannotCarry) {
  EXPECT_FALSE(EncodeP2osCommand(p2os::kVel, 40000).ok());
  EXPECT_FALSE(EncodeP2osPacket(p2os::kVel, Bytes(198, 0)).ok());
  EXPECT_TRUE(EncodeP2osPacket(p2os::kVel, Bytes(197, 0)).ok());  // count exactly 200
}

TEST(P2osParserTest, FindsPacketsInGarbageSplitReadsAndBadChecksums) {
  Bytes stream = {0x00, 0xFA, 0x17};  // garbage, a lone header byte
  const Bytes vel = *EncodeP2osCommand(p2os::kVel, 200);
  Bytes corrupt = vel;
  corrupt.back() ^= 0x01;  // wrong checksum
  stream.insert(stream.end(), corrupt.begin(), corrupt.end());
  stream.insert(stream.end(), vel.begin(), vel.end());
  const Bytes sync2 = EncodeP2osCommand(p2os::kSync2);
  stream.insert(stream.end(), sync2.begin(), sync2.end());

  P2osParser parser;
  std::vector<P2osPacket> packets;
  for (std::uint8_t byte : stream) {  // one byte per read: the worst a serial port does
    parser.Feed(&byte, 1);
    while (auto p = parser.Next()) packets.push_back(*p);
  }
  ASSERT_EQ(packets.size(), 2u);
  EXPECT_EQ(packets[0].id, p2os::kVel);
  EXPECT_EQ(packets[0].payload, (Bytes{0x3B, 0xC8, 0x00}));
  EXPECT_EQ(packets[1].id, p2os::kSync2);
  EXPECT_TRUE(packets[1].payload.empty());
  EXPECT_EQ(parser.bad_checksums(), 1u);
  EXPECT_GT(parser.skipped_bytes(), 0u);
}

TEST(P2osParserTest, RandomBytesNeverCrashAndValidPacketsStillComeThrough) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  P2osParser parser;
  int found = 0;
  const Bytes pulse = EncodeP2osCommand(p2os::kPulse);
  for (int round = 0; round < 2000; ++round) {
    Bytes noise(1 + byte(rng) % 64);
    for (auto& b : noise) b = static_cast<std::uint8_t>(byte(rng));
    // Now and then a header with a count that promises more than ever comes.
    if (round % 97 == 0) noise.insert(noise.end(), {0xFA, 0xFB, 0xC8});
    parser.Feed(noise.data(), noise.size());
    parser.Feed(pulse.data(), pulse.size());
    while (auto p = parser.Next()) found += p->id == p2os::kPulse && p->payload.empty();
  }
  // A header inside the noise can swallow the following pulse (its count says so); most
  // pulses still arrive.
  EXPECT_GT(found, 1500);
}

}  // namespace
}  // namespace waymark::adapters
