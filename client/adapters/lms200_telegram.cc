#include "client/adapters/lms200_telegram.h"

#include "absl/strings/str_cat.h"

namespace waymark::adapters {
namespace {
constexpr std::uint16_t kPolynomial = 0x8005;
constexpr std::size_t kMaxPayload = 812;  // the LMS200's largest telegram body
}  // namespace

std::uint16_t Lms200Crc(const std::uint8_t* data, std::size_t size) {
  std::uint16_t crc = 0;
  std::uint8_t previous = 0;
  for (std::size_t i = 0; i < size; ++i) {
    if (crc & 0x8000) {
      crc = static_cast<std::uint16_t>((crc & 0x7FFF) << 1);
      crc ^= kPolynomial;
    } else {
      crc = static_cast<std::uint16_t>(crc << 1);
    }
    crc ^= static_cast<std::uint16_t>(data[i] | (previous << 8));
    previous = data[i];
  }
  return crc;
}

absl::StatusOr<std::vector<std::uint8_t>> EncodeLms200Telegram(
    const std::vector<std::uint8_t>& command_and_data, std::uint8_t address) {
  if (command_and_data.empty() || command_and_data.size() > kMaxPayload) {
    return absl::InvalidArgumentError(absl::StrCat(
        "LMS200 telegram body must hold 1 to ", kMaxPayload, " bytes, got ",
        command_and_data.size()));
  }
  const auto length = static_cast<std::uint16_t>(command_and_data.size());
  std::vector<std::uint8_t> telegram = {lms200::kStx, address,
                                        static_cast<std::uint8_t>(length & 0xFF),
                                        static_cast<std::uint8_t>(length >> 8)};
  telegram.insert(telegram.end(), command_and_data.begin(), command_and_data.end());
  const std::uint16_t crc = Lms200Crc(telegram.data(), telegram.size());
  telegram.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  telegram.push_back(static_cast<std::uint8_t>(crc >> 8));
  return telegram;
}

}  // namespace waymark::adapters
