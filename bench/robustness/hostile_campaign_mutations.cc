#include "bench/robustness/hostile_campaign_mutations.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/unknown_field_set.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_join.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::bench::hostile {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;

size_t Uniform(Rng& rng, size_t lo, size_t hi) {  // inclusive
  return std::uniform_int_distribution<size_t>(lo, hi)(rng);
}
bool Chance(Rng& rng, double p) { return std::bernoulli_distribution(p)(rng); }
template <class T>
const T& OneOf(Rng& rng, const std::vector<T>& values) {
  return values[Uniform(rng, 0, values.size() - 1)];
}

std::string RandomBytes(Rng& rng, size_t n) {
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}
std::string RandomPrintable(Rng& rng, size_t n) {
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(Uniform(rng, 0x20, 0x7e));
  return s;
}

// --- the wire format, for the operators that corrupt it on purpose ---------------------------

std::string Varint(uint64_t v) {
  std::string s;
  while (v >= 0x80) {
    s.push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  s.push_back(static_cast<char>(v));
  return s;
}

bool ReadVarint(const std::string& s, size_t& pos, size_t end, uint64_t* value) {
  *value = 0;
  for (int shift = 0; shift < 64 && pos < end; shift += 7) {
    const uint8_t b = static_cast<uint8_t>(s[pos++]);
    *value |= static_cast<uint64_t>(b & 0x7f) << shift;
    if ((b & 0x80) == 0) return true;
  }
  return false;
}

// One field on the wire. A length-delimited field of a known message type keeps its payload as
// children, so a corruption deep inside is re-wrapped with correct outer lengths: only the
// chosen field is wrong, the rest of the message still frames correctly.
struct WireNode {
  uint64_t number = 0;
  int wire_type = 0;
  std::string tag;     // as sent (wrong_wire_type rewrites it)
  std::string value;   // varint or fixed bytes; the payload of a length-delimited leaf
  std::string length;  // forced length prefix (huge_length); empty = the payload's true size
  bool message = false;
  std::vector<WireNode> children;
};

bool ParseWire(const std::string& s, size_t pos, size_t end, const Descriptor* type,
               std::vector<WireNode>* out) {
  while (pos < end) {
    WireNode node;
    const size_t tag_begin = pos;
    uint64_t tag = 0;
    if (!ReadVarint(s, pos, end, &tag)) return false;
    node.tag = s.substr(tag_begin, pos - tag_begin);
    node.number = tag >> 3;
    node.wire_type = static_cast<int>(tag & 7);
    const size_t value_begin = pos;
    switch (node.wire_type) {
      case 0: {
        uint64_t ignored = 0;
        if (!ReadVarint(s, pos, end, &ignored)) return false;
        node.value = s.substr(value_begin, pos - value_begin);
        break;
      }
      case 1:
      case 5: {
        const size_t width = node.wire_type == 1 ? 8 : 4;
        if (end - pos < width) return false;
        node.value = s.substr(pos, width);
        pos += width;
        break;
      }
      case 2: {
        uint64_t length = 0;
        if (!ReadVarint(s, pos, end, &length) || length > end - pos) return false;
        const FieldDescriptor* field =
            type == nullptr ? nullptr : type->FindFieldByNumber(static_cast<int>(node.number));
        if (field != nullptr && field->type() == FieldDescriptor::TYPE_MESSAGE &&
            ParseWire(s, pos, pos + length, field->message_type(), &node.children)) {
          node.message = true;
        } else {
          node.children.clear();
          node.value = s.substr(pos, length);
        }
        pos += length;
        break;
      }
      default:
        return false;  // groups: none of the API's messages has them
    }
    out->push_back(std::move(node));
  }
  return true;
}

std::string SerializeWire(const std::vector<WireNode>& nodes) {
  std::string s;
  for (const WireNode& node : nodes) {
    s += node.tag;
    if (node.wire_type != 2) {
      s += node.value;
      continue;
    }
    const std::string payload = node.message ? SerializeWire(node.children) : node.value;
    s += node.length.empty() ? Varint(payload.size()) : node.length;
    s += payload;
  }
  return s;
}

void CollectNodes(std::vector<WireNode>& nodes, std::vector<WireNode*>* out) {
  for (WireNode& node : nodes) {
    out->push_back(&node);
    if (node.message) CollectNodes(node.children, out);
  }
}

// Applies `change` to one field on the wire chosen among those `eligible`; false when `bytes`
// have no such field (or do not parse as wire format any more).
bool MutateWireField(std::string& bytes, const Descriptor* type, Rng& rng,
                     const std::function<bool(const WireNode&)>& eligible,
                     const std::function<void(WireNode&)>& change) {
  std::vector<WireNode> nodes;
  if (!ParseWire(bytes, 0, bytes.size(), type, &nodes)) return false;
  std::vector<WireNode*> all;
  CollectNodes(nodes, &all);
  std::vector<WireNode*> candidates;
  for (WireNode* node : all) {
    if (eligible(*node)) candidates.push_back(node);
  }
  if (candidates.empty()) return false;
  change(*OneOf(rng, candidates));
  bytes = SerializeWire(nodes);
  return true;
}

// --- byte operators ------------------------------------------------------------------------

bool BitFlip(std::string& s, const Descriptor*, Rng& rng) {
  if (s.empty()) s.push_back(static_cast<char>(rng()));
  const size_t flips = Chance(rng, 0.7) ? 1 : Uniform(rng, 2, 16);
  for (size_t i = 0; i < flips; ++i) s[Uniform(rng, 0, s.size() - 1)] ^= 1 << Uniform(rng, 0, 7);
  return true;
}

bool Truncate(std::string& s, const Descriptor*, Rng& rng) {
  if (s.empty()) return false;
  s.resize(Uniform(rng, 0, s.size() - 1));
  return true;
}

bool RandomReplace(std::string& s, const Descriptor*, Rng& rng) {
  const size_t max = OneOf<size_t>(rng, {0, 16, 256, 4096, 65536});
  s = RandomBytes(rng, Uniform(rng, 0, max));
  return true;
}

bool InsertRun(std::string& s, const Descriptor*, Rng& rng) {
  const size_t at = Uniform(rng, 0, s.size());
  const size_t n = Uniform(rng, 1, Chance(rng, 0.8) ? 16 : 4096);
  s.insert(at, Chance(rng, 0.5) ? RandomBytes(rng, n) : std::string(n, OneOf<char>(rng, {0, '\xff', 'A'})));
  return true;
}

bool DuplicateRun(std::string& s, const Descriptor*, Rng& rng) {
  if (s.empty()) return false;
  const size_t from = Uniform(rng, 0, s.size() - 1);
  const size_t length = Uniform(rng, 1, std::min<size_t>(s.size() - from, 4096));
  const std::string run = s.substr(from, length);
  std::string copies;
  for (size_t i = Uniform(rng, 1, 16); i > 0; --i) copies += run;
  s.insert(Uniform(rng, 0, s.size()), copies);
  return true;
}

// A length prefix far beyond the bytes that follow: a parser that trusts it allocates or reads
// past the end.
bool HugeLength(std::string& s, const Descriptor* type, Rng& rng) {
  return MutateWireField(
      s, type, rng, [](const WireNode& n) { return n.wire_type == 2; },
      [&rng](WireNode& n) {
        const size_t size = n.message ? SerializeWire(n.children).size() : n.value.size();
        n.length = OneOf<std::string>(
            rng, {Varint(size + 1), Varint(size + 1000), Varint(0x7fffffffu), Varint(0xffffffffu),
                  Varint((uint64_t{1} << 32) + 5), Varint(uint64_t{1} << 63),
                  Varint(std::numeric_limits<uint64_t>::max()),
                  std::string(9, '\xff') + "\x01",   // overlong, 2^64-1
                  std::string(11, '\xff')});         // never ends
      });
}

bool WrongWireType(std::string& s, const Descriptor* type, Rng& rng) {
  return MutateWireField(
      s, type, rng, [](const WireNode&) { return true; },
      [&rng](WireNode& n) {
        int wire_type = n.wire_type;
        while (wire_type == n.wire_type) wire_type = static_cast<int>(Uniform(rng, 0, 7));
        n.tag = Varint((n.number << 3) | static_cast<uint64_t>(wire_type));
      });
}

// A varint written with more bytes than needed (legal up to 10) or never ending.
bool OverlongVarint(std::string& s, const Descriptor* type, Rng& rng) {
  return MutateWireField(
      s, type, rng, [](const WireNode& n) { return n.wire_type == 0; },
      [&rng](WireNode& n) {
        std::string v = n.value;
        v.back() = static_cast<char>(v.back() | 0x80);
        const size_t pad = Chance(rng, 0.5) ? 10 - std::min<size_t>(v.size(), 9) : 12;
        v += std::string(pad - 1, '\x80');
        v.push_back(Chance(rng, 0.5) ? '\x00' : '\x80');
        n.value = v;
      });
}

// Groups nested deeper than protobuf's recursion limit (100), appended as an unknown field.
bool DeepNesting(std::string& s, const Descriptor*, Rng& rng) {
  const size_t depth = OneOf<size_t>(rng, {99, 101, 1000, 100000});
  const uint64_t number = 15000;
  const std::string open = Varint((number << 3) | 3), close = Varint((number << 3) | 4);
  std::string nest;
  for (size_t i = 0; i < depth; ++i) nest += open;
  const bool balanced = Chance(rng, 0.7);
  for (size_t i = 0; balanced && i < depth; ++i) nest += close;
  s += nest;
  return true;
}

// --- message operators (reflection) ----------------------------------------------------------

struct Slot {
  Message* message;
  const FieldDescriptor* field;
};

// Every field of `m` and of its submessages; with `create`, some unset submessages are created
// first, so that fields a valid request leaves empty get their turn.
void CollectSlots(Message& m, int depth, Rng& rng, bool create, std::vector<Slot>* slots,
                  std::vector<Message*>* messages) {
  messages->push_back(&m);
  const Descriptor* type = m.GetDescriptor();
  const Reflection* reflection = m.GetReflection();
  for (int i = 0; i < type->field_count(); ++i) {
    const FieldDescriptor* field = type->field(i);
    slots->push_back({&m, field});
    if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE || depth >= 4) continue;
    if (field->is_repeated()) {
      const int n = reflection->FieldSize(m, field);
      for (int j = 0; j < std::min(n, 4); ++j) {
        CollectSlots(*reflection->MutableRepeatedMessage(&m, field, j), depth + 1, rng, create,
                     slots, messages);
      }
      if (n == 0 && create && Chance(rng, 0.2)) {
        CollectSlots(*reflection->AddMessage(&m, field), depth + 1, rng, create, slots, messages);
      }
      continue;
    }
    // Creating another member of a oneof would clear the set one under pointers taken already.
    const bool set = reflection->HasField(m, field);
    const bool may_create = create && field->containing_oneof() == nullptr && Chance(rng, 0.3);
    if (set || may_create) {
      CollectSlots(*reflection->MutableMessage(&m, field), depth + 1, rng, create, slots,
                   messages);
    }
  }
}

std::vector<Slot> SlotsWhere(Message& m, Rng& rng, const std::function<bool(const FieldDescriptor*)>& keep,
                             std::vector<Message*>* messages = nullptr) {
  std::vector<Slot> all, kept;
  std::vector<Message*> ignored;
  CollectSlots(m, 0, rng, true, &all, messages != nullptr ? messages : &ignored);
  for (const Slot& slot : all) {
    if (keep(slot.field)) kept.push_back(slot);
  }
  return kept;
}

bool IsNumber(const FieldDescriptor* f) {
  return f->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE &&
         f->cpp_type() != FieldDescriptor::CPPTYPE_STRING;
}

template <class T>
std::vector<T> ExtremeFloats() {
  using L = std::numeric_limits<T>;
  return {L::quiet_NaN(), -L::quiet_NaN(), L::infinity(), -L::infinity(), L::max(), L::lowest(),
          L::denorm_min(), T(-0.0), T(-1), T(1e30), static_cast<T>(1e300), static_cast<T>(-1e300)};
}

// Sets `slot` to a number no robot measures (or adds one to a repeated field).
void SetExtreme(const Slot& slot, Rng& rng) {
  Message* m = slot.message;
  const FieldDescriptor* f = slot.field;
  const Reflection* r = m->GetReflection();
  const bool repeated = f->is_repeated();
  const int size = repeated ? r->FieldSize(*m, f) : 0;
  const bool replace = repeated && size > 0 && Chance(rng, 0.5);
  const int index = replace ? static_cast<int>(Uniform(rng, 0, size - 1)) : 0;
#define WAYMARK_SET(Type, value)                                        \
  do {                                                                  \
    if (!repeated) r->Set##Type(m, f, value);                           \
    else if (replace) r->SetRepeated##Type(m, f, index, value);         \
    else for (int k = Uniform(rng, 1, 3); k > 0; --k) r->Add##Type(m, f, value); \
  } while (0)
  switch (f->cpp_type()) {
    case FieldDescriptor::CPPTYPE_DOUBLE: WAYMARK_SET(Double, OneOf(rng, ExtremeFloats<double>())); break;
    case FieldDescriptor::CPPTYPE_FLOAT: WAYMARK_SET(Float, OneOf(rng, ExtremeFloats<float>())); break;
    case FieldDescriptor::CPPTYPE_INT32:
      WAYMARK_SET(Int32, OneOf<int32_t>(rng, {std::numeric_limits<int32_t>::min(),
                                              std::numeric_limits<int32_t>::max(), -1, 0}));
      break;
    case FieldDescriptor::CPPTYPE_INT64:
      WAYMARK_SET(Int64, OneOf<int64_t>(rng, {std::numeric_limits<int64_t>::min(),
                                              std::numeric_limits<int64_t>::max(), -1, 0}));
      break;
    case FieldDescriptor::CPPTYPE_UINT32:
      WAYMARK_SET(UInt32, OneOf<uint32_t>(rng, {std::numeric_limits<uint32_t>::max(), 0x80000000u,
                                                1000000000u, 0}));
      break;
    case FieldDescriptor::CPPTYPE_UINT64:
      WAYMARK_SET(UInt64, OneOf<uint64_t>(rng, {std::numeric_limits<uint64_t>::max(),
                                                uint64_t{1} << 63, 0}));
      break;
    case FieldDescriptor::CPPTYPE_BOOL: WAYMARK_SET(Bool, Chance(rng, 0.5)); break;
    case FieldDescriptor::CPPTYPE_ENUM:  // proto3 enums are open: any int32 goes on the wire
      WAYMARK_SET(EnumValue, OneOf<int>(rng, {std::numeric_limits<int32_t>::min(),
                                              std::numeric_limits<int32_t>::max(), -1, 99}));
      break;
    default: break;
  }
#undef WAYMARK_SET
}

bool ExtremeNumber(Message& m, Rng& rng) {
  std::vector<Slot> slots = SlotsWhere(m, rng, IsNumber);
  if (slots.empty()) return false;
  std::shuffle(slots.begin(), slots.end(), rng);
  const size_t n = Chance(rng, 0.1) ? slots.size() : Uniform(rng, 1, std::min<size_t>(3, slots.size()));
  for (size_t i = 0; i < n; ++i) SetExtreme(slots[i], rng);
  return true;
}

// Sizes of oversized strings: mostly what fits the server's 32 MiB message limit, now and then
// one beyond it.
size_t OversizeBytes(Rng& rng) {
  const double p = std::uniform_real_distribution<double>(0, 1)(rng);
  if (p < 0.30) return 1 << 10;
  if (p < 0.60) return 64 << 10;
  if (p < 0.85) return 1 << 20;
  if (p < 0.99) return 8 << 20;
  return 33 << 20;
}

void SetString(const Slot& slot, const std::string& value) {
  const Reflection* r = slot.message->GetReflection();
  if (slot.field->is_repeated()) {
    r->AddString(slot.message, slot.field, value);
  } else {
    r->SetString(slot.message, slot.field, value);
  }
}

bool IsString(const FieldDescriptor* f) { return f->cpp_type() == FieldDescriptor::CPPTYPE_STRING; }

bool OversizeString(Message& m, Rng& rng) {
  const std::vector<Slot> slots = SlotsWhere(m, rng, IsString);
  if (slots.empty()) return false;
  const size_t n = OversizeBytes(rng);
  const Slot& slot = OneOf(rng, slots);
  SetString(slot, Chance(rng, 0.8) ? RandomPrintable(rng, n) : RandomBytes(rng, n));
  return true;
}

// Names and labels a hostile client tries: paths, format strings, SQL, control characters,
// invalid UTF-8 (which makes a proto3 string unparsable), names just over the limits.
bool HostileString(Message& m, Rng& rng) {
  const std::vector<Slot> slots = SlotsWhere(m, rng, IsString);
  if (slots.empty()) return false;
  static const std::vector<std::string> kStrings = {
      "",
      std::string("a\0b", 3),
      "../../../../etc/passwd",
      "%s%s%s%n%n",
      "'; DROP TABLE crossing_database; --",
      "\" OR 1=1 --",
      "\xe2\x80\xae\xe2\x80\x8b",  // right-to-left override, zero width space
      "\xff\xfe\xc0\xaf",          // not UTF-8
      std::string(65, 'n'),
      std::string(257, 'x'),
      "\x01\x02\x1b[2J\r\n",
      "wm_" + std::string(64, 'f'),
      "con", ".", "..", " ", "*",
  };
  SetString(OneOf(rng, slots), OneOf(rng, kStrings));
  return true;
}

bool OversizeRepeated(Message& m, Rng& rng) {
  const std::vector<Slot> slots =
      SlotsWhere(m, rng, [](const FieldDescriptor* f) { return f->is_repeated(); });
  if (slots.empty()) return false;
  const Slot& slot = OneOf(rng, slots);
  const Reflection* r = slot.message->GetReflection();
  const bool scalar = IsNumber(slot.field);
  const size_t count = OneOf<size_t>(rng, scalar ? std::vector<size_t>{1000, 100000, 1000000}
                                                 : std::vector<size_t>{100, 10000, 100000});
  for (size_t i = 0; i < count; ++i) {
    switch (slot.field->cpp_type()) {
      case FieldDescriptor::CPPTYPE_DOUBLE: r->AddDouble(slot.message, slot.field, 1.5); break;
      case FieldDescriptor::CPPTYPE_FLOAT: r->AddFloat(slot.message, slot.field, 1.5f); break;
      case FieldDescriptor::CPPTYPE_INT32: r->AddInt32(slot.message, slot.field, 1); break;
      case FieldDescriptor::CPPTYPE_INT64: r->AddInt64(slot.message, slot.field, 1); break;
      case FieldDescriptor::CPPTYPE_UINT32: r->AddUInt32(slot.message, slot.field, 1); break;
      case FieldDescriptor::CPPTYPE_UINT64: r->AddUInt64(slot.message, slot.field, 1); break;
      case FieldDescriptor::CPPTYPE_BOOL: r->AddBool(slot.message, slot.field, true); break;
      case FieldDescriptor::CPPTYPE_ENUM: r->AddEnumValue(slot.message, slot.field, 1); break;
      case FieldDescriptor::CPPTYPE_STRING: r->AddString(slot.message, slot.field, "x"); break;
      case FieldDescriptor::CPPTYPE_MESSAGE: {
        // Copies of the first element when there is one (each valid on its own), else empty ones.
        Message* added = r->AddMessage(slot.message, slot.field);
        if (r->FieldSize(*slot.message, slot.field) > 1) {
          added->CopyFrom(r->GetRepeatedMessage(*slot.message, slot.field, 0));
        }
        break;
      }
    }
  }
  return true;
}

bool UnknownFields(Message& m, Rng& rng) {
  std::vector<Message*> messages;
  SlotsWhere(m, rng, [](const FieldDescriptor*) { return false; }, &messages);
  Message* target = OneOf(rng, messages);
  google::protobuf::UnknownFieldSet* unknown =
      target->GetReflection()->MutableUnknownFields(target);
  for (size_t i = Uniform(rng, 1, 5); i > 0; --i) {
    int number = 0;
    do {
      number = static_cast<int>(OneOf<uint64_t>(
          rng, {Uniform(rng, 1, 40), 1000, 19500, Uniform(rng, 20000, 536870911), 536870911}));
    } while (target->GetDescriptor()->FindFieldByNumber(number) != nullptr);
    switch (Uniform(rng, 0, 4)) {
      case 0: unknown->AddVarint(number, rng()); break;
      case 1: unknown->AddFixed32(number, static_cast<uint32_t>(rng())); break;
      case 2: unknown->AddFixed64(number, rng()); break;
      case 3: unknown->AddLengthDelimited(number, RandomBytes(rng, Uniform(rng, 0, 1024))); break;
      default: unknown->AddGroup(number)->AddVarint(1, rng()); break;
    }
  }
  return true;
}

bool ClearFields(Message& m, Rng& rng) {
  std::vector<Slot> set = SlotsWhere(m, rng, [](const FieldDescriptor*) { return true; });
  set.erase(std::remove_if(set.begin(), set.end(),
                           [](const Slot& s) {
                             const Reflection* r = s.message->GetReflection();
                             return s.field->is_repeated() ? r->FieldSize(*s.message, s.field) == 0
                                                           : !r->HasField(*s.message, s.field);
                           }),
            set.end());
  if (set.empty()) return false;
  // One field: clearing a submessage frees the slots collected inside it, which are not used again.
  const Slot& slot = OneOf(rng, set);
  slot.message->GetReflection()->ClearField(slot.message, slot.field);
  return true;
}

// Writes `value` big-endian in the `bytes` bytes at `at`.
void PutBigEndian(std::string& s, size_t at, uint32_t value, int bytes) {
  for (int i = bytes - 1; i >= 0; --i, value >>= 8) s[at + i] = static_cast<char>(value & 0xff);
}

// A PNG whose header claims `width` x `height` (CRC fixed, so decoders believe it).
std::string PatchPngSize(std::string png, uint32_t width, uint32_t height) {
  if (png.size() < 33) return png;
  PutBigEndian(png, 16, width, 4);
  PutBigEndian(png, 20, height, 4);
  const uint32_t crc = static_cast<uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(png.data() + 12), 17));
  PutBigEndian(png, 29, crc, 4);
  return png;
}

// A JPEG whose frame header (SOF0/SOF2) claims `width` x `height`.
std::string PatchJpegSize(std::string jpeg, uint16_t width, uint16_t height) {
  for (size_t i = 2; i + 9 < jpeg.size(); ++i) {
    const auto marker = static_cast<uint8_t>(jpeg[i + 1]);
    if (static_cast<uint8_t>(jpeg[i]) == 0xff && (marker == 0xc0 || marker == 0xc2)) {
      PutBigEndian(jpeg, i + 5, height, 2);
      PutBigEndian(jpeg, i + 7, width, 2);
      break;
    }
  }
  return jpeg;
}

std::string Encode(const char* extension, const cv::Mat& image) {
  std::vector<uchar> bytes;
  try {
    if (!cv::imencode(extension, image, bytes)) return "";
  } catch (const cv::Exception&) {
    return "";
  }
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

HostileImages::HostileImages() {
  const cv::Mat view = testing::CropView(testing::MakePanorama(21), 90);
  const cv::Mat pixel(1, 1, CV_8UC3, cv::Scalar(10, 200, 30));
  cv::Mat gray, deep, rgba, large;
  cv::cvtColor(view, gray, cv::COLOR_BGR2GRAY);
  gray.convertTo(deep, CV_16U, 256);
  cv::cvtColor(view, rgba, cv::COLOR_BGR2BGRA);
  cv::resize(view, large, cv::Size(4000, 3000));
  const std::string jpeg = Encode(".jpg", view), png = Encode(".png", pixel);
  // 12000 x 12000 zero pixels: about 150 KB as PNG, 432 MB once decoded as colour.
  const std::string zeros = Encode(".png", cv::Mat::zeros(12000, 12000, CV_8UC1));
  for (const std::string& image :
       {png, Encode(".jpg", pixel), Encode(".png", deep), Encode(".png", rgba),
        Encode(".jpg", gray), Encode(".bmp", view), Encode(".ppm", view), Encode(".tiff", view),
        Encode(".webp", view), Encode(".jpg", large), zeros, jpeg.substr(0, jpeg.size() / 2),
        jpeg.substr(0, 600), PatchPngSize(png, 65535, 65535), PatchPngSize(png, 0, 0),
        PatchJpegSize(jpeg, 65500, 65500), PatchJpegSize(jpeg, 1, 1),
        std::string("\x89PNG\r\n\x1a\n", 8), std::string("GIF89a\x01\x00\x01\x00", 10)}) {
    if (!image.empty()) images_.push_back(image);  // empty: a codec this OpenCV lacks
  }
  images_.push_back("");  // no image at all
}

const std::string& HostileImages::Pick(Rng& rng) const { return OneOf(rng, images_); }

Mutator::Mutator(const HostileImages* images) : images_(images) {
  // Weights: the byte-level corruptions and extreme numbers are the bulk, the expensive ones
  // (oversized strings and repeated fields, deep nesting) rarer.
  ops_ = {
      {"bit_flip", nullptr, BitFlip, 6},
      {"truncate", nullptr, Truncate, 4},
      {"random_bytes", nullptr, RandomReplace, 2},
      {"insert_run", nullptr, InsertRun, 2},
      {"duplicate_run", nullptr, DuplicateRun, 2},
      {"huge_length", nullptr, HugeLength, 3},
      {"wrong_wire_type", nullptr, WrongWireType, 3},
      {"overlong_varint", nullptr, OverlongVarint, 1},
      {"deep_nesting", nullptr, DeepNesting, 1},
      {"extreme_number", ExtremeNumber, nullptr, 8},
      {"oversize_string", OversizeString, nullptr, 2},
      {"hostile_string", HostileString, nullptr, 3},
      {"oversize_repeated", OversizeRepeated, nullptr, 1},
      {"unknown_fields", UnknownFields, nullptr, 3},
      {"clear_fields", ClearFields, nullptr, 2},
      {"image_swap", [this](Message& m, Rng& rng) { return ImageSwap(m, rng); }, nullptr, 3},
  };
}

bool Mutator::ImageSwap(google::protobuf::Message& m, Rng& rng) const {
  const std::vector<Slot> slots = SlotsWhere(
      m, rng, [](const FieldDescriptor* f) { return f->type() == FieldDescriptor::TYPE_BYTES; });
  if (slots.empty() || images_ == nullptr) return false;
  SetString(OneOf(rng, slots), images_->Pick(rng));
  return true;
}

std::vector<std::string> Mutator::OperatorNames() {
  std::vector<std::string> names;
  for (const Operator& op : Mutator(nullptr).ops_) names.push_back(op.name);
  return names;
}

const Mutator::Operator& Mutator::Pick(Rng& rng) const {
  std::vector<int> weights;
  for (const Operator& op : ops_) weights.push_back(op.weight);
  return ops_[std::discrete_distribution<size_t>(weights.begin(), weights.end())(rng)];
}

Mutation Mutator::Mutate(const google::protobuf::Message& valid, Rng& rng) const {
  const double p = std::uniform_real_distribution<double>(0, 1)(rng);
  const size_t count = p < 0.7 ? 1 : p < 0.9 ? 2 : 3;
  std::vector<const Operator*> chosen;
  for (size_t i = 0; i < count; ++i) chosen.push_back(&Pick(rng));
  // Structure first: a byte corruption on top of a changed message, never the reverse (the
  // corrupted bytes may not parse back into a message).
  std::stable_sort(chosen.begin(), chosen.end(), [](const Operator* a, const Operator* b) {
    return a->on_bytes == nullptr && b->on_bytes != nullptr;
  });
  std::unique_ptr<Message> message(valid.New());
  message->CopyFrom(valid);
  std::vector<std::string> applied;
  Mutation out;
  bool serialized = false;
  for (const Operator* op : chosen) {
    if (op->on_bytes == nullptr) {
      if (op->on_message(*message, rng)) applied.push_back(op->name);
      continue;
    }
    if (!serialized) {
      out.bytes = message->SerializeAsString();
      serialized = true;
    }
    if (op->on_bytes(out.bytes, valid.GetDescriptor(), rng)) applied.push_back(op->name);
  }
  if (!serialized) out.bytes = message->SerializeAsString();
  if (applied.empty()) {  // nothing applied (e.g. no string field to oversize): flip bits
    BitFlip(out.bytes, valid.GetDescriptor(), rng);
    applied.push_back("bit_flip");
  }
  out.kind = absl::StrJoin(applied, "+");
  return out;
}

bool Parses(const google::protobuf::Descriptor* type, const std::string& bytes) {
  const Message* prototype =
      google::protobuf::MessageFactory::generated_factory()->GetPrototype(type);
  std::unique_ptr<Message> message(prototype->New());
  return message->ParseFromString(bytes);
}

}  // namespace waymark::bench::hostile
