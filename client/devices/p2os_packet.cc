#include "client/devices/p2os_packet.h"

#include <cstdlib>

#include "absl/strings/str_cat.h"

namespace waymark::adapters {

std::uint16_t P2osChecksum(const std::uint8_t* data, std::size_t size) {
  std::uint32_t sum = 0;
  std::size_t i = 0;
  for (; i + 1 < size; i += 2) {
    sum += (static_cast<std::uint32_t>(data[i]) << 8) | data[i + 1];
    sum &= 0xFFFF;
  }
  if (i < size) sum ^= data[i];
  return static_cast<std::uint16_t>(sum);
}

absl::StatusOr<std::vector<std::uint8_t>> EncodeP2osPacket(std::uint8_t id,
                                                           const std::vector<std::uint8_t>& args) {
  const std::size_t count = 1 + args.size() + 2;
  if (count > p2os::kMaxCount) {
    return absl::InvalidArgumentError(
        absl::StrCat("P2OS packet of ", count, " bytes exceeds the protocol's 200"));
  }
  std::vector<std::uint8_t> packet = {p2os::kHeader0, p2os::kHeader1,
                                      static_cast<std::uint8_t>(count), id};
  packet.insert(packet.end(), args.begin(), args.end());
  const std::uint16_t checksum = P2osChecksum(packet.data() + 3, packet.size() - 3);
  packet.push_back(static_cast<std::uint8_t>(checksum >> 8));
  packet.push_back(static_cast<std::uint8_t>(checksum & 0xFF));
  return packet;
}

std::vector<std::uint8_t> EncodeP2osCommand(std::uint8_t id) { return *EncodeP2osPacket(id, {}); }

absl::StatusOr<std::vector<std::uint8_t>> EncodeP2osCommand(std::uint8_t id, int value) {
  if (value < -32767 || value > 32767) {
    return absl::InvalidArgumentError(
        absl::StrCat("P2OS integer argument ", value, " is outside [-32767, 32767]"));
  }
  const unsigned magnitude = static_cast<unsigned>(std::abs(value));
  return EncodeP2osPacket(id, {value < 0 ? p2os::kNegativeInt : p2os::kPositiveInt,
                               static_cast<std::uint8_t>(magnitude & 0xFF),
                               static_cast<std::uint8_t>(magnitude >> 8)});
}

void P2osParser::Feed(const std::uint8_t* data, std::size_t size) {
  buffer_.insert(buffer_.end(), data, data + size);
}

std::optional<P2osPacket> P2osParser::Next() {
  while (true) {
    // Find the header.
    while (buffer_.size() >= 2 && !(buffer_[0] == p2os::kHeader0 && buffer_[1] == p2os::kHeader1)) {
      buffer_.pop_front();
      ++skipped_bytes_;
    }
    if (buffer_.size() < 3) return std::nullopt;
    const int count = buffer_[2];
    if (count < 3 || count > p2os::kMaxCount) {
      ++bad_counts_;
      buffer_.pop_front();  // resync from the next byte
      ++skipped_bytes_;
      continue;
    }
    if (buffer_.size() < 3u + count) return std::nullopt;  // wait for the rest
    std::vector<std::uint8_t> body(buffer_.begin() + 3, buffer_.begin() + 3 + count);
    const std::uint16_t expected = P2osChecksum(body.data(), body.size() - 2);
    const std::uint16_t got =
        static_cast<std::uint16_t>((body[body.size() - 2] << 8) | body[body.size() - 1]);
    if (expected != got) {
      ++bad_checksums_;
      buffer_.pop_front();  // the header may have been data: resync from the next byte
      ++skipped_bytes_;
      continue;
    }
    buffer_.erase(buffer_.begin(), buffer_.begin() + 3 + count);
    P2osPacket packet;
    packet.id = body[0];
    packet.payload.assign(body.begin() + 1, body.end() - 2);
    return packet;
  }
}

}  // namespace waymark::adapters
