#ifndef WAYMARK_SERVER_COMMON_BINARY_IO_H_
#define WAYMARK_SERVER_COMMON_BINARY_IO_H_

// Little helpers for the sessions' checkpoint formats (laser and visual): fixed-width
// little-endian fields appended to a string, and a reader that fails (instead of reading past the
// end) on truncated input.

#include <cstdint>
#include <algorithm>
#include <cstring>
#include <string>

#include "absl/strings/string_view.h"

namespace waymark {

class BinaryWriter {
 public:
  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  std::string Take() { return std::move(out_); }

 private:
  std::string out_;
};

class BinaryReader {
 public:
  explicit BinaryReader(absl::string_view in) : in_(in) {}
  template <typename T>
  bool Get(T* value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (in_.size() < sizeof(T)) return false;
    std::memcpy(value, in_.data(), sizeof(T));
    in_.remove_prefix(sizeof(T));
    return true;
  }
  bool done() const { return in_.empty(); }
  size_t remaining() const { return in_.size(); }
  // What is left, unread.
  absl::string_view Rest() const { return in_; }
  void Skip(size_t n) { in_.remove_prefix(std::min(n, in_.size())); }

 private:
  absl::string_view in_;
};

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_BINARY_IO_H_
