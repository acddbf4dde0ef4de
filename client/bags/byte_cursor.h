#ifndef WAYMARK_CLIENT_BAGS_BYTE_CURSOR_H_
#define WAYMARK_CLIENT_BAGS_BYTE_CURSOR_H_

// Little-endian reads over a byte range that never go past its end: every read says whether it
// succeeded, so a record parser turns a short or lying record into an error instead of reading
// past the buffer. Used by the ROS 1 and MCAP record parsers.

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace waymark::bags {

class ByteCursor {
 public:
  explicit ByteCursor(std::string_view bytes) : bytes_(bytes) {}

  size_t position() const { return position_; }
  size_t remaining() const { return bytes_.size() - position_; }
  bool empty() const { return remaining() == 0; }

  template <typename T>
  bool Read(T* value) {
    static_assert(std::is_integral_v<T>);
    if (remaining() < sizeof(T)) return false;
    // The formats are little-endian; so is every machine Waymark builds for (x86-64, arm64).
    std::memcpy(value, bytes_.data() + position_, sizeof(T));
    position_ += sizeof(T);
    return true;
  }

  // `size` bytes as a view into the buffer.
  bool Bytes(uint64_t size, std::string_view* out) {
    if (size > remaining()) return false;
    *out = bytes_.substr(position_, size);
    position_ += size;
    return true;
  }

  // A string or byte array preceded by its length as a `Length` integer.
  template <typename Length>
  bool Prefixed(std::string_view* out) {
    Length size = 0;
    const size_t start = position_;
    if (!Read(&size) || !Bytes(size, out)) {
      position_ = start;
      return false;
    }
    return true;
  }
  template <typename Length>
  bool PrefixedString(std::string* out) {
    std::string_view view;
    if (!Prefixed<Length>(&view)) return false;
    out->assign(view);
    return true;
  }

  bool Skip(uint64_t size) {
    if (size > remaining()) return false;
    position_ += size;
    return true;
  }

 private:
  std::string_view bytes_;
  size_t position_ = 0;
};

// std::string_view prefix test (Debian's absl::string_view is its own type, not std's).
inline bool HasPrefix(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_BYTE_CURSOR_H_
