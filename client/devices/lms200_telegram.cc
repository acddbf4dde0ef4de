#include "client/devices/lms200_telegram.h"

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

void Lms200Parser::Feed(const std::uint8_t* data, std::size_t size) {
  buffer_.insert(buffer_.end(), data, data + size);
}

std::optional<Lms200Telegram> Lms200Parser::Next() {
  while (true) {
    while (!buffer_.empty() && buffer_.front() != lms200::kStx) {
      if (buffer_.front() == lms200::kNak) ++naks_;
      if (buffer_.front() != lms200::kAck && buffer_.front() != lms200::kNak) ++skipped_bytes_;
      buffer_.pop_front();
    }
    if (buffer_.size() < 4) return std::nullopt;
    const std::size_t length = buffer_[2] | (buffer_[3] << 8);
    if (length == 0 || length > kMaxPayload) {
      buffer_.pop_front();  // not a telegram start: resync
      ++skipped_bytes_;
      continue;
    }
    const std::size_t total = 4 + length + 2;
    if (buffer_.size() < total) return std::nullopt;
    std::vector<std::uint8_t> telegram(buffer_.begin(), buffer_.begin() + total);
    const std::uint16_t crc = Lms200Crc(telegram.data(), total - 2);
    if ((telegram[total - 2] | (telegram[total - 1] << 8)) != crc) {
      ++bad_crcs_;
      buffer_.pop_front();
      ++skipped_bytes_;
      continue;
    }
    buffer_.erase(buffer_.begin(), buffer_.begin() + total);
    Lms200Telegram out;
    out.address = telegram[1];
    out.command = telegram[4];
    out.data.assign(telegram.begin() + 5, telegram.end() - 2);
    return out;
  }
}

absl::StatusOr<Lms200Scan> DecodeLms200Scan(const Lms200Telegram& telegram) {
  if (telegram.command != 0xB0) {
    return absl::InvalidArgumentError(
        absl::StrCat("LMS200 telegram command 0x", absl::Hex(telegram.command),
                     " is not a scan reply (0xB0)"));
  }
  const std::vector<std::uint8_t>& d = telegram.data;
  if (d.size() < 2) return absl::InvalidArgumentError("LMS200 scan reply without a count word");
  const int word = d[0] | (d[1] << 8);
  const std::size_t count = word & 0x07FF;
  const int units = (word >> 14) & 0x03;
  if (units > 1) {
    return absl::InvalidArgumentError(absl::StrCat("LMS200 scan reply units ", units,
                                                   " are neither cm (0) nor mm (1)"));
  }
  if (d.size() < 2 + 2 * count) {
    return absl::InvalidArgumentError(absl::StrCat("LMS200 scan reply claims ", count,
                                                   " values but carries ", (d.size() - 2) / 2));
  }
  const double scale = units == 1 ? 0.001 : 0.01;
  Lms200Scan scan;
  scan.ranges_m.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const int value = (d[2 + 2 * i] | (d[3 + 2 * i] << 8)) & 0x1FFF;
    scan.ranges_m.push_back(static_cast<float>(value * scale));
  }
  return scan;
}

}  // namespace waymark::adapters
