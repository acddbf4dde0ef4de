#include "client/ros/ros_wire.h"

#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"

namespace waymark::ros {

const char* WireFormatName(WireFormat format) {
  return format == WireFormat::kRos1 ? "ros1" : "cdr";
}

WireReader::WireReader(WireFormat format, std::string_view data, MessageOrigin origin)
    : format_(format), data_(data), origin_(std::move(origin)) {
  if (format_ != WireFormat::kCdr) return;
  if (data_.size() < 4) {
    Fail("encapsulation header", "a CDR message starts with 4 bytes; it has fewer");
    return;
  }
  const uint8_t kind = static_cast<uint8_t>(data_[1]);
  switch (kind) {
    case 0x00: big_endian_ = true; break;   // CDR_BE
    case 0x01: break;                        // CDR_LE
    case 0x06: case 0x10: big_endian_ = true; max_alignment_ = 4; break;  // plain CDR2, BE
    case 0x07: case 0x11: max_alignment_ = 4; break;                      // plain CDR2, LE
    default:
      Fail("encapsulation header",
           absl::StrCat("encapsulation kind 0x", absl::Hex(static_cast<unsigned>(kind), absl::kZeroPad2),
                        " (parameter-list or delimited CDR) is not read here; plain CDR (0x00, "
                        "0x01) and plain CDR2 (0x06, 0x07, 0x10, 0x11) are"));
      return;
  }
  pos_ = 4;
  origin_offset_ = 4;
}

void WireReader::Fail(const char* field, absl::string_view problem) {
  if (!status_.ok()) return;
  status_ = absl::InvalidArgumentError(
      absl::StrCat("topic ", origin_.topic, " (", origin_.type, ", ", WireFormatName(format_),
                   "): field '", field, "': ", problem));
}

bool WireReader::Take(size_t size, size_t alignment, const char* field) {
  if (!status_.ok()) return false;
  if (format_ == WireFormat::kCdr && alignment > 1) {
    const size_t align = alignment < max_alignment_ ? alignment : max_alignment_;
    const size_t misalignment = (pos_ - origin_offset_) % align;
    if (misalignment != 0) pos_ += align - misalignment;
  }
  if (pos_ > data_.size() || data_.size() - pos_ < size) {
    Fail(field, absl::StrCat("needs ", size, " byte(s) at offset ", pos_, " but the message has ",
                             data_.size(), " bytes (truncated, or not this type)"));
    return false;
  }
  return true;
}

template <typename T>
T WireReader::ReadPrimitive(const char* field) {
  if (!Take(sizeof(T), sizeof(T), field)) return T{};
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, data_.data() + pos_, sizeof(T));
  pos_ += sizeof(T);
  // The host is little-endian (x86-64, aarch64): only big-endian CDR needs a swap.
  if (big_endian_) {
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  }
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

uint8_t WireReader::U8(const char* field) { return ReadPrimitive<uint8_t>(field); }
bool WireReader::Bool(const char* field) { return ReadPrimitive<uint8_t>(field) != 0; }
uint32_t WireReader::U32(const char* field) { return ReadPrimitive<uint32_t>(field); }
int32_t WireReader::I32(const char* field) { return ReadPrimitive<int32_t>(field); }
float WireReader::F32(const char* field) { return ReadPrimitive<float>(field); }
double WireReader::F64(const char* field) { return ReadPrimitive<double>(field); }

uint32_t WireReader::Count(const char* field, size_t min_element_bytes) {
  const uint32_t count = U32(field);
  if (!status_.ok()) return 0;
  if (min_element_bytes > 0 && count > remaining() / min_element_bytes) {
    Fail(field, absl::StrCat("says ", count, " element(s) but only ", remaining(),
                             " bytes are left (truncated, or not this type)"));
    return 0;
  }
  return count;
}

std::string_view WireReader::Bytes(size_t n, const char* field) {
  if (!Take(n, 1, field)) return {};
  std::string_view bytes = data_.substr(pos_, n);
  pos_ += n;
  return bytes;
}

std::string WireReader::String(const char* field) {
  const uint32_t length = Count(field, 1);
  if (!status_.ok()) return {};
  if (format_ == WireFormat::kRos1) return std::string(Bytes(length, field));
  // CDR: the length counts the NUL. 0 is what some writers send for an empty string.
  if (length == 0) return {};
  std::string_view bytes = Bytes(length, field);
  if (!status_.ok()) return {};
  if (bytes.back() != '\0') {
    Fail(field, "a CDR string must end in a NUL byte; this one does not (not this type?)");
    return {};
  }
  return std::string(bytes.substr(0, length - 1));
}

int64_t WireReader::TimeNs(const char* field) {
  int64_t sec = 0;
  if (format_ == WireFormat::kRos1) {
    sec = U32(field);
  } else {
    sec = I32(field);
  }
  const uint32_t nsec = U32(field);
  if (!status_.ok()) return 0;
  if (nsec >= 1000000000u) {
    Fail(field, absl::StrCat("nanoseconds ", nsec, " are not below one second"));
    return 0;
  }
  return sec * 1000000000 + nsec;
}

void WireReader::ExpectEnd() {
  if (!status_.ok()) return;
  const size_t left = remaining();
  const size_t allowed = format_ == WireFormat::kCdr ? 3 : 0;
  if (left > allowed) {
    Fail("(end)", absl::StrCat(left, " byte(s) are left after the last field of ", data_.size(),
                               ": the message is not this type, or another version of it"));
  }
}

}  // namespace waymark::ros
