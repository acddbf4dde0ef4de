#ifndef WAYMARK_CLIENT_ADAPTERS_LMS200_TELEGRAM_H_
#define WAYMARK_CLIENT_ADAPTERS_LMS200_TELEGRAM_H_

// SICK LMS200 telegrams (RS-232/RS-422, issue 5):
//   STX 0x02, address (0x00 to the sensor, replies from 0x80), length (uint16 little-endian:
//   command + data), command, data, CRC16 little-endian over the whole telegram from STX.
// The CRC is SICK's variant with polynomial 0x8005: per byte, shift left and XOR the polynomial
// if the top bit was set, then XOR in `byte | previous_byte << 8`.

#include <cstdint>
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

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_ADAPTERS_LMS200_TELEGRAM_H_
