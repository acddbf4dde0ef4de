#ifndef WAYMARK_SERVER_COMMON_QUOTE_H_
#define WAYMARK_SERVER_COMMON_QUOTE_H_

// Client text in the server's answers and error messages (issue 35). A proto3 string must be valid
// UTF-8: Python's protobuf (and every strict parser) refuses the whole message otherwise
// (DecodeError), so an answer that quoted a client's name cut in the middle of a multi-byte
// character was lost whole, views already stored included. And an answer must not carry an
// unbounded client field back (a 1 MB `position` echoed in a skipped view).
//
// So every place that puts client input (names, ids, positions, topics, paths) into an answer or
// a status message goes through one of these:
// - QuoteClientText: for messages. The text in double quotes, C-escaped where it is not printable
//   UTF-8 (\n, \t, \", \\, \xNN for control characters and for bytes that are not UTF-8), cut at a
//   character boundary after `max_chars` characters with "..." before the closing quote.
// - BoundClientText: for answer fields that echo a client's value so the client can match it
//   (a skipped view's crossing and position): the value itself when it is valid UTF-8 and at
//   most `max_chars` characters long, else its valid prefix, bytes that are not UTF-8 escaped as
//   \xNN, and "..." after a cut.
// Both count characters (code points; an escaped byte is one), never bytes, and always return
// valid UTF-8 of at most 4 * max_chars + 5 bytes.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace waymark {

// The default length of a quote: long enough to recognise a name, short enough for any answer.
inline constexpr size_t kMaxQuotedChars = 64;

namespace quote_internal {

// The length of the UTF-8 character at text[at] (1-4), or 0 when the bytes there are not one
// (a stray continuation byte, an overlong form, a surrogate, beyond U+10FFFF, or cut short).
inline size_t Utf8CharLength(std::string_view text, size_t at) {
  const auto byte = [&](size_t i) { return static_cast<uint8_t>(text[i]); };
  const uint8_t b0 = byte(at);
  if (b0 < 0x80) return 1;
  size_t length = 0;
  uint8_t low = 0x80, high = 0xBF;  // the range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    length = 2;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    length = 3;
    if (b0 == 0xE0) low = 0xA0;   // no overlong forms
    if (b0 == 0xED) high = 0x9F;  // no surrogates
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    length = 4;
    if (b0 == 0xF0) low = 0x90;   // no overlong forms
    if (b0 == 0xF4) high = 0x8F;  // nothing beyond U+10FFFF
  } else {
    return 0;
  }
  if (at + length > text.size()) return 0;
  if (byte(at + 1) < low || byte(at + 1) > high) return 0;
  for (size_t i = 2; i < length; ++i) {
    if ((byte(at + i) & 0xC0) != 0x80) return 0;
  }
  return length;
}

inline void AppendHexByte(uint8_t b, std::string* out) {
  static constexpr char kHex[] = "0123456789abcdef";
  out->append("\\x");
  out->push_back(kHex[b >> 4]);
  out->push_back(kHex[b & 0xF]);
}

// The common walk: `escape_all` escapes control characters, quotes and backslashes as well as
// bytes that are not UTF-8 (for messages); otherwise only the latter.
inline std::string Bounded(std::string_view text, size_t max_chars, bool escape_all) {
  std::string out;
  out.reserve(std::min(text.size(), 4 * max_chars) + 8);
  size_t chars = 0;
  size_t at = 0;
  while (at < text.size()) {
    if (chars == max_chars) {
      out.append("...");
      return out;
    }
    const size_t length = Utf8CharLength(text, at);
    const uint8_t b = static_cast<uint8_t>(text[at]);
    if (length == 0) {
      AppendHexByte(b, &out);
      at += 1;
    } else if (escape_all && length == 1 && (b < 0x20 || b == 0x7F || b == '"' || b == '\\')) {
      switch (b) {
        case '\n': out.append("\\n"); break;
        case '\r': out.append("\\r"); break;
        case '\t': out.append("\\t"); break;
        case '"': out.append("\\\""); break;
        case '\\': out.append("\\\\"); break;
        default: AppendHexByte(b, &out); break;
      }
      at += 1;
    } else {
      out.append(text.substr(at, length));
      at += length;
    }
    ++chars;
  }
  return out;
}

}  // namespace quote_internal

// Whether `text` is entirely valid UTF-8 (what a proto3 string field must hold).
inline bool IsValidUtf8(std::string_view text) {
  for (size_t at = 0; at < text.size();) {
    const size_t length = quote_internal::Utf8CharLength(text, at);
    if (length == 0) return false;
    at += length;
  }
  return true;
}

// `text` quoted for a message: "text", escaped and cut as the file comment says.
inline std::string QuoteClientText(std::string_view text, size_t max_chars = kMaxQuotedChars) {
  std::string out = "\"";
  out += quote_internal::Bounded(text, max_chars, /*escape_all=*/true);
  out += '"';
  return out;
}

// `text` for an answer field that echoes it: unchanged when it is valid UTF-8 of at most
// `max_chars` characters; otherwise as the file comment says.
inline std::string BoundClientText(std::string_view text, size_t max_chars = kMaxQuotedChars) {
  return quote_internal::Bounded(text, max_chars, /*escape_all=*/false);
}

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_QUOTE_H_
