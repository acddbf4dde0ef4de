#ifndef WAYMARK_CLIENT_DEVICES_LMS200_TELEGRAM_H_
#define WAYMARK_CLIENT_DEVICES_LMS200_TELEGRAM_H_

// SICK LMS200 telegrams (RS-232/RS-422, issue 5):
//   STX 0x02, address (0x00 to the sensor, replies from 0x80), length (uint16 little-endian:
//   command + data), command, data, CRC16 little-endian over the whole telegram from STX.
// The CRC is SICK's variant with polynomial 0x8005: per byte, shift left and XOR the polynomial
// if the top bit was set, then XOR in `byte | previous_byte << 8`.

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::adapters {

namespace lms200 {
inline constexpr std::uint8_t kStx = 0x02;
inline constexpr std::uint8_t kToSensor = 0x00;
inline constexpr std::uint8_t kAck = 0x06;
inline constexpr std::uint8_t kNak = 0x15;
}  // namespace lms200

std::uint16_t Lms200Crc(const std::uint8_t* data, std::size_t size);

// A whole telegram to `address` carrying `command_and_data` (the length field counts it).
// INVALID_ARGUMENT when empty or longer than the protocol's 812 bytes.
absl::StatusOr<std::vector<std::uint8_t>> EncodeLms200Telegram(
    const std::vector<std::uint8_t>& command_and_data, std::uint8_t address = lms200::kToSensor);

// One telegram from the sensor.
struct Lms200Telegram {
  std::uint8_t address = 0;
  std::uint8_t command = 0;
  std::vector<std::uint8_t> data;  // after the command byte, CRC excluded
};

// Splits the serial byte stream into telegrams. ACK/NAK bytes and anything before an STX are
// skipped (NAKs counted); a telegram whose length exceeds 812 or whose CRC does not match is
// dropped and counted, and parsing resumes at the next STX.
class Lms200Parser {
 public:
  void Feed(const std::uint8_t* data, std::size_t size);
  std::optional<Lms200Telegram> Next();

  std::uint64_t naks() const { return naks_; }
  std::uint64_t bad_crcs() const { return bad_crcs_; }
  std::uint64_t skipped_bytes() const { return skipped_bytes_; }

 private:
  std::deque<std::uint8_t> buffer_;
  std::uint64_t naks_ = 0;
  std::uint64_t bad_crcs_ = 0;
  std::uint64_t skipped_bytes_ = 0;
};

// A scan reply (command 0xB0): a count word (low 11 bits = number of values, bits 14-15 = units:
// 0 cm, 1 mm), then one uint16 per value whose low 13 bits are the range.
struct Lms200Scan {
  std::vector<float> ranges_m;
};
absl::StatusOr<Lms200Scan> DecodeLms200Scan(const Lms200Telegram& telegram);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_LMS200_TELEGRAM_H_
