#ifndef WAYMARK_CLIENT_DEVICES_P2OS_PACKET_H_
#define WAYMARK_CLIENT_DEVICES_P2OS_PACKET_H_

// ARCOS / P2OS packet framing for the Pioneer base (issue 5):
//   0xFA 0xFB, count (bytes that follow, checksum included, at most 200), id, arguments,
//   checksum (2 bytes, high first): the bytes from the id on summed as big-endian 16-bit words,
//   masked to 16 bits, with the last byte XORed in when their number is odd.
// Integer arguments: type byte 0x3B (positive), 0x1B (negative; the magnitude follows) or 0x2B
// (string), then the value little-endian.

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::adapters {

namespace p2os {
inline constexpr std::uint8_t kHeader0 = 0xFA;
inline constexpr std::uint8_t kHeader1 = 0xFB;
inline constexpr int kMaxCount = 200;
inline constexpr std::uint8_t kPositiveInt = 0x3B;
inline constexpr std::uint8_t kNegativeInt = 0x1B;
inline constexpr std::uint8_t kString = 0x2B;
// Commands (id): the client side of the protocol.
inline constexpr std::uint8_t kPulse = 0, kSync0 = 0, kOpen = 1, kSync1 = 1, kClose = 2,
                              kSync2 = 2, kEnable = 4, kSetOdometry = 7, kVel = 11, kRotVel = 21,
                              kStop = 29, kVel2 = 32, kEmergencyStop = 55;
}  // namespace p2os

// Checksum of the bytes from the packet id on (the checksum itself excluded).
std::uint16_t P2osChecksum(const std::uint8_t* data, std::size_t size);

// A whole packet for `id` with the given argument bytes. INVALID_ARGUMENT beyond 200 bytes.
absl::StatusOr<std::vector<std::uint8_t>> EncodeP2osPacket(std::uint8_t id,
                                                           const std::vector<std::uint8_t>& args);
// A command without argument (SYNC0, PULSE, OPEN, ...).
std::vector<std::uint8_t> EncodeP2osCommand(std::uint8_t id);
// A command with one integer argument in [-32767, 32767] (INVALID_ARGUMENT outside).
absl::StatusOr<std::vector<std::uint8_t>> EncodeP2osCommand(std::uint8_t id, int value);

// One packet from the robot: its id (the first byte after the count) and what follows it, the
// checksum excluded.
struct P2osPacket {
  std::uint8_t id = 0;
  std::vector<std::uint8_t> payload;
};

// Splits a serial byte stream into packets. Bytes before a header, packets with a count outside
// [3, 200] and packets whose checksum does not match are dropped and counted; parsing resumes at
// the next header, so garbage, short reads and unplugged cables never stop it.
class P2osParser {
 public:
  void Feed(const std::uint8_t* data, std::size_t size);
  std::optional<P2osPacket> Next();

  std::uint64_t skipped_bytes() const { return skipped_bytes_; }
  std::uint64_t bad_checksums() const { return bad_checksums_; }
  std::uint64_t bad_counts() const { return bad_counts_; }

 private:
  std::deque<std::uint8_t> buffer_;
  std::uint64_t skipped_bytes_ = 0;
  std::uint64_t bad_checksums_ = 0;
  std::uint64_t bad_counts_ = 0;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_P2OS_PACKET_H_
