#ifndef WAYMARK_CLIENT_ROS_ROS_WIRE_H_
#define WAYMARK_CLIENT_ROS_ROS_WIRE_H_

// The two wire formats ROS messages come in, read field by field with every read bounds-checked:
//
// ROS 1: little-endian, packed (no padding); string and T[] = uint32 length then the bytes or
//   elements; T[N] has no length; time = uint32 sec + uint32 nsec; std_msgs/Header starts with
//   a uint32 seq.
// CDR (ROS 2, XCDR1 as rmw writes it): a 4-byte encapsulation header {0x00, kind, options x2},
//   kind 0x01 CDR_LE or 0x00 CDR_BE; then every primitive is aligned to its size counted from the
//   byte after that header (8-byte values to 4 in the plain XCDR2 kinds 0x06/0x07/0x10/0x11);
//   string = uint32 length including the NUL, the bytes, the NUL; T[] = uint32 count then the
//   elements; builtin_interfaces/Time = int32 sec + uint32 nanosec; the Header has no seq.
//
// A read past the end, a string without its NUL, a count larger than the bytes left could hold,
// or an encapsulation kind not read here does not throw or crash: the reader remembers the first
// problem (naming the topic, the type and the field being read), returns zeros from then on, and
// status() gives it. Decoders read every field and check status() once at the end.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace waymark::ros {

enum class WireFormat { kRos1, kCdr };

// "ros1" or "cdr".
const char* WireFormatName(WireFormat format);

// Where a message came from, for the errors.
struct MessageOrigin {
  std::string topic;  // "/scan"
  std::string type;   // "sensor_msgs/LaserScan"
};

class WireReader {
 public:
  // `data` must outlive the reader. For CDR the encapsulation header is read here.
  WireReader(WireFormat format, std::string_view data, MessageOrigin origin);

  WireFormat format() const { return format_; }
  bool ok() const { return status_.ok(); }
  const absl::Status& status() const { return status_; }
  size_t offset() const { return pos_; }
  size_t remaining() const { return pos_ <= data_.size() ? data_.size() - pos_ : 0; }

  uint8_t U8(const char* field);
  bool Bool(const char* field);
  uint32_t U32(const char* field);
  int32_t I32(const char* field);
  float F32(const char* field);
  double F64(const char* field);
  std::string String(const char* field);
  // A time (ROS 1 time or builtin_interfaces/Time) as nanoseconds since the epoch.
  int64_t TimeNs(const char* field);
  // The length of a T[] whose elements take at least `min_element_bytes` each: refused when the
  // bytes left cannot hold that many (a corrupt count never allocates gigabytes).
  uint32_t Count(const char* field, size_t min_element_bytes);
  // `n` raw bytes (uint8[] contents), unaligned.
  std::string_view Bytes(size_t n, const char* field);

  // The message must end here: ROS 1 has no padding, so bytes left over mean another definition
  // of the type; CDR may end in up to 3 bytes of padding (rmw pads to 4), more is the same error.
  void ExpectEnd();

  // Records `problem` about `field` as the reader's error unless there is one already.
  void Fail(const char* field, absl::string_view problem);

 private:
  // Aligns (CDR) and checks that `size` bytes are there; false (and the error) when not.
  bool Take(size_t size, size_t alignment, const char* field);
  template <typename T>
  T ReadPrimitive(const char* field);

  WireFormat format_;
  std::string_view data_;
  MessageOrigin origin_;
  size_t pos_ = 0;
  size_t origin_offset_ = 0;  // CDR alignment is counted from here (after the header)
  size_t max_alignment_ = 8;  // 4 in XCDR2
  bool big_endian_ = false;
  absl::Status status_;
};

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_ROS_WIRE_H_
