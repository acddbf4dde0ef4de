#include "client/bags/mcap_file.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <set>
#include <string_view>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/bags/byte_cursor.h"
#include "client/bags/chunked_reader.h"

namespace waymark::bags {
namespace {

constexpr uint8_t kOpHeader = 0x01;
constexpr uint8_t kOpFooter = 0x02;
constexpr uint8_t kOpSchema = 0x03;
constexpr uint8_t kOpChannel = 0x04;
constexpr uint8_t kOpMessage = 0x05;
constexpr uint8_t kOpChunk = 0x06;
constexpr uint8_t kOpStatistics = 0x0B;
constexpr uint8_t kOpChunkIndex = 0x08;
constexpr uint8_t kOpDataEnd = 0x0F;

constexpr uint64_t kMagicSize = 8;
constexpr uint64_t kFooterRecordSize = 1 + 8 + 8 + 8 + 4;
// Message record content before the payload: channel id, sequence, log time, publish time.
constexpr uint64_t kMessagePrefix = 2 + 4 + 8 + 8;
// Schemas, channels and the like are small; a record outside chunks claiming more is damage.
constexpr uint64_t kMaxSmallRecord = 64u << 20;

struct Schema {
  std::string name;
  std::string encoding;
  std::string data;
};

class McapFile final : public ChunkedReader {
 public:
  McapFile(RandomFile file, std::string format)
      : ChunkedReader(std::move(file)), format_(std::move(format)) {}

  absl::Status Open();
  absl::StatusOr<BagSummary> Summary() override;

 protected:
  absl::Status BuildTable() override;
  absl::StatusOr<std::string_view> MessageAt(std::string_view chunk, uint64_t offset) const override;

 private:
  // Schema, channel, statistics and chunk index records; false on a malformed one.
  bool TakeRecord(uint8_t op, std::string_view content);
  bool TakeSchema(std::string_view content);
  bool TakeChannel(std::string_view content);
  absl::Status ReadSummary();
  // The records of an expanded chunk (or of the data section's unchunked messages).
  void ScanRecords(uint32_t chunk, std::string_view records);

  std::string format_;
  std::string profile_;
  std::map<uint16_t, Schema> schemas_;
  bool has_statistics_ = false;
  uint64_t stat_messages_ = 0;
  int64_t stat_start_ = 0, stat_end_ = 0;
  std::map<int, int64_t> stat_counts_;
  std::set<std::string> compressions_;
};

bool McapFile::TakeSchema(std::string_view content) {
  ByteCursor cursor(content);
  uint16_t id = 0;
  Schema schema;
  std::string_view data;
  if (!cursor.Read(&id) || !cursor.PrefixedString<uint32_t>(&schema.name) ||
      !cursor.PrefixedString<uint32_t>(&schema.encoding) || !cursor.Prefixed<uint32_t>(&data)) {
    return false;
  }
  schema.data.assign(data);
  if (id != 0) schemas_.emplace(id, std::move(schema));  // id 0 is "no schema" (spec)
  return true;
}

bool McapFile::TakeChannel(std::string_view content) {
  ByteCursor cursor(content);
  uint16_t id = 0, schema_id = 0;
  BagConnection connection;
  std::string_view metadata;
  if (!cursor.Read(&id) || !cursor.Read(&schema_id) ||
      !cursor.PrefixedString<uint32_t>(&connection.topic) ||
      !cursor.PrefixedString<uint32_t>(&connection.encoding_name) ||
      !cursor.Prefixed<uint32_t>(&metadata)) {
    return false;
  }
  connection.id = id;
  ByteCursor entries(metadata);
  while (!entries.empty()) {
    std::string key, value;
    if (!entries.PrefixedString<uint32_t>(&key) || !entries.PrefixedString<uint32_t>(&value)) break;
    if (key == "md5sum") connection.md5sum = value;
    if (key == "callerid") connection.callerid = value;
  }
  auto schema = schemas_.find(schema_id);
  if (schema != schemas_.end()) {
    connection.raw_type = schema->second.name;
    if (schema->second.encoding == "ros1msg" || schema->second.encoding == "ros2msg" ||
        schema->second.encoding == "ros2idl" || schema->second.encoding == "jsonschema") {
      connection.definition = schema->second.data;
    }
  }
  connection.type = NormalizeType(connection.raw_type);
  if (connection.encoding_name == "ros1") {
    connection.encoding = MessageEncoding::kRos1;
  } else if (connection.encoding_name == "cdr") {
    connection.encoding = MessageEncoding::kCdr;
  }
  AddConnection(std::move(connection));
  return true;
}

bool McapFile::TakeRecord(uint8_t op, std::string_view content) {
  switch (op) {
    case kOpHeader: {
      ByteCursor cursor(content);
      return cursor.PrefixedString<uint32_t>(&profile_);
    }
    case kOpSchema: return TakeSchema(content);
    case kOpChannel: return TakeChannel(content);
    case kOpStatistics: {
      ByteCursor cursor(content);
      uint16_t schema_count = 0;
      uint32_t channel_count = 0, attachment_count = 0, metadata_count = 0, chunk_count = 0;
      uint64_t start = 0, end = 0;
      std::string_view counts;
      if (!cursor.Read(&stat_messages_) || !cursor.Read(&schema_count) ||
          !cursor.Read(&channel_count) || !cursor.Read(&attachment_count) ||
          !cursor.Read(&metadata_count) || !cursor.Read(&chunk_count) || !cursor.Read(&start) ||
          !cursor.Read(&end) || !cursor.Prefixed<uint32_t>(&counts)) {
        return false;
      }
      stat_start_ = static_cast<int64_t>(start);
      stat_end_ = static_cast<int64_t>(end);
      ByteCursor entries(counts);
      while (!entries.empty()) {
        uint16_t channel = 0;
        uint64_t count = 0;
        if (!entries.Read(&channel) || !entries.Read(&count)) return false;
        stat_counts_[channel] = AddCounts(stat_counts_[channel], CountFrom(count));
      }
      has_statistics_ = true;
      return true;
    }
    case kOpChunkIndex: {
      ByteCursor cursor(content);
      uint64_t skip = 0;
      std::string_view offsets;
      std::string compression;
      for (int i = 0; i < 4; ++i) cursor.Read(&skip);  // times, chunk offset and length
      if (!cursor.Prefixed<uint32_t>(&offsets) || !cursor.Read(&skip) ||
          !cursor.PrefixedString<uint32_t>(&compression)) {
        return false;
      }
      compressions_.insert(compression.empty() ? "none" : compression);
      return true;
    }
    default: return true;  // attachments, metadata, indexes: not needed to read messages
  }
}

absl::Status McapFile::ReadSummary() {
  if (file_.size() < 2 * kMagicSize + kFooterRecordSize) {
    return absl::OutOfRangeError(absl::StrCat("only ", file_.size(), " bytes"));
  }
  absl::StatusOr<std::string> tail =
      file_.Read(file_.size() - kMagicSize - kFooterRecordSize, kMagicSize + kFooterRecordSize);
  if (!tail.ok()) return tail.status();
  if (tail->compare(kFooterRecordSize, kMagicSize, kMcapMagic, kMagicSize) != 0) {
    return absl::OutOfRangeError("no closing magic");
  }
  ByteCursor footer(*tail);
  uint8_t op = 0;
  uint64_t length = 0, summary_start = 0, summary_offset_start = 0;
  if (!footer.Read(&op) || op != kOpFooter || !footer.Read(&length) || length != 20 ||
      !footer.Read(&summary_start) || !footer.Read(&summary_offset_start)) {
    return absl::DataLossError("malformed footer record");
  }
  if (summary_start == 0) return absl::NotFoundError("the file has no summary section");
  const uint64_t footer_at = file_.size() - kMagicSize - kFooterRecordSize;
  const uint64_t summary_end = summary_offset_start != 0 ? summary_offset_start : footer_at;
  if (summary_start < kMagicSize || summary_start > summary_end || summary_end > footer_at) {
    return absl::DataLossError("the footer points outside the file");
  }
  absl::StatusOr<std::string> summary = file_.Read(summary_start, summary_end - summary_start);
  if (!summary.ok()) return summary.status();
  ByteCursor cursor(*summary);
  while (!cursor.empty()) {
    uint8_t record_op = 0;
    std::string_view content;
    if (!cursor.Read(&record_op) || !cursor.Prefixed<uint64_t>(&content) ||
        !TakeRecord(record_op, content)) {
      return absl::DataLossError("malformed record in the summary section");
    }
  }
  return absl::OkStatus();
}

absl::Status McapFile::Open() {
  // The header record, for the profile.
  absl::StatusOr<std::string> head = file_.ReadUpTo(kMagicSize, 9);
  if (head.ok() && head->size() == 9 && static_cast<uint8_t>((*head)[0]) == kOpHeader) {
    uint64_t length = 0;
    std::memcpy(&length, head->data() + 1, 8);
    if (length <= kMaxSmallRecord) {
      if (absl::StatusOr<std::string> header = file_.Read(kMagicSize + 9, length); header.ok()) {
        TakeRecord(kOpHeader, *header);
      }
    }
  }
  absl::Status summary = ReadSummary();
  if (summary.ok() && !connections_.empty()) return absl::OkStatus();
  if (!summary.ok() && summary.code() == absl::StatusCode::kOutOfRange) {
    Warn(absl::StrCat("the MCAP file has no footer (its recording was cut short: ",
                      summary.message(), "); read by scanning its records"));
  } else if (!summary.ok() && summary.code() != absl::StatusCode::kNotFound) {
    Warn(absl::StrCat("the MCAP summary is unreadable (", summary.message(),
                      "); read by scanning the data section"));
  }
  // No channels from the summary: walk the data section now, so connections() is complete.
  has_statistics_ = false;
  return EnsureTable();
}

void McapFile::ScanRecords(uint32_t chunk, std::string_view records) {
  ByteCursor cursor(records);
  while (!cursor.empty()) {
    const uint64_t at = cursor.position();
    uint8_t op = 0;
    std::string_view content;
    if (!cursor.Read(&op) || !cursor.Prefixed<uint64_t>(&content)) {
      Warn(absl::StrCat("a chunk at file offset ", chunks_[chunk].data_offset,
                        " ends in a cut record; the messages before it are kept"));
      return;
    }
    if (op == kOpMessage) {
      ByteCursor message(content);
      uint16_t channel = 0;
      uint32_t sequence = 0;
      uint64_t log_time = 0;
      if (message.Read(&channel) && message.Read(&sequence) && message.Read(&log_time) &&
          content.size() >= kMessagePrefix) {
        messages_.push_back({static_cast<int64_t>(log_time), chunk, at, channel});
      }
    } else if (!TakeRecord(op, content)) {
      Warn(absl::StrCat("malformed record (op ", int{op}, ") in a chunk is skipped"));
    }
  }
}

absl::Status McapFile::BuildTable() {
  uint64_t offset = kMagicSize;
  while (offset < file_.size()) {
    absl::StatusOr<std::string> head = file_.ReadUpTo(offset, 9);
    if (!head.ok()) return head.status();
    if (head->size() < 9) {
      Warn(absl::StrCat("the MCAP file ends in a cut record at offset ", offset,
                        "; the messages before it are kept"));
      break;
    }
    const uint8_t op = static_cast<uint8_t>((*head)[0]);
    uint64_t length = 0;
    std::memcpy(&length, head->data() + 1, 8);
    const uint64_t content_at = offset + 9;
    const bool cut = length > file_.size() - content_at;
    if (cut) {
      Warn(absl::StrCat("record at offset ", offset, " claims ", length,
                        " bytes but the file ends sooner (a truncated file?); the messages "
                        "before it are kept"));
      if (op != kOpChunk) break;
      length = file_.size() - content_at;  // a cut chunk: the messages it holds up to the cut
    }
    if (op == kOpDataEnd || op == kOpFooter) break;
    if (op == kOpChunk) {
      // start and end time, uncompressed size and CRC, compression, then the records' length.
      absl::StatusOr<std::string> fixed = file_.ReadUpTo(content_at, std::min<uint64_t>(length, 4096));
      if (!fixed.ok()) return fixed.status();
      ByteCursor cursor(*fixed);
      uint64_t start = 0, end = 0, uncompressed = 0, records_length = 0;
      uint32_t crc = 0;
      std::string compression;
      if (!cursor.Read(&start) || !cursor.Read(&end) || !cursor.Read(&uncompressed) ||
          !cursor.Read(&crc) || !cursor.PrefixedString<uint32_t>(&compression) ||
          !cursor.Read(&records_length) ||
          (records_length > length - cursor.position() && !cut)) {
        Warn(absl::StrCat("malformed chunk record at offset ", offset, " is skipped"));
      } else {
        absl::StatusOr<Compression> codec = ParseCompression(compression);
        compressions_.insert(compression.empty() ? "none" : compression);
        if (!codec.ok()) {
          Warn(absl::StrCat("chunk at offset ", offset, " is skipped: ", codec.status().message()));
        } else {
          if (cut) records_length = std::min<uint64_t>(records_length, length - cursor.position());
          const uint32_t index = static_cast<uint32_t>(chunks_.size());
          chunks_.push_back({content_at + cursor.position(), records_length, *codec,
                             *codec == Compression::kNone ? records_length : uncompressed, cut});
          absl::StatusOr<std::string> expanded = ExpandChunk(chunks_.back());
          if (!expanded.ok()) {
            Warn(absl::StrCat("chunk at offset ", offset, " is skipped: ", expanded.status().message()));
          } else if (crc != 0 && !cut && crc32(0L, reinterpret_cast<const Bytef*>(expanded->data()),
                                       static_cast<uInt>(expanded->size())) != crc) {
            Warn(absl::StrCat("chunk at offset ", offset, " fails its CRC and is skipped"));
          } else {
            ScanRecords(index, *expanded);
          }
        }
      }
    } else if (op == kOpMessage) {
      // A message outside chunks: a one-record "chunk" read straight from the file.
      const uint32_t index = static_cast<uint32_t>(chunks_.size());
      chunks_.push_back({offset, 9 + length, Compression::kNone, 9 + length, false});
      absl::StatusOr<std::string> record = ExpandChunk(chunks_.back());
      if (!record.ok()) return record.status();
      ScanRecords(index, *record);
      compressions_.insert("none");
    } else if (op == kOpSchema || op == kOpChannel || op == kOpHeader) {
      if (length > kMaxSmallRecord) {
        Warn(absl::StrCat("record at offset ", offset, " claims ", length, " bytes; skipped"));
      } else if (absl::StatusOr<std::string> content = file_.Read(content_at, length);
                 !content.ok() || !TakeRecord(op, *content)) {
        Warn(absl::StrCat("malformed record (op ", int{op}, ") at offset ", offset, " is skipped"));
      }
    }
    offset = content_at + length;
    if (cut) break;
  }
  // Channels whose schema came later in the file are complete now; nothing else to resolve.
  return absl::OkStatus();
}

absl::StatusOr<std::string_view> McapFile::MessageAt(std::string_view chunk, uint64_t offset) const {
  ByteCursor cursor(chunk);
  std::string_view content;
  uint8_t op = 0;
  if (!cursor.Skip(offset) || !cursor.Read(&op) || op != kOpMessage ||
      !cursor.Prefixed<uint64_t>(&content) || content.size() < kMessagePrefix) {
    return absl::DataLossError("no message record there");
  }
  return content.substr(kMessagePrefix);
}

absl::StatusOr<BagSummary> McapFile::Summary() {
  std::string format = format_;
  if (!profile_.empty() && format_ == "MCAP") format = absl::StrCat("MCAP (profile ", profile_, ")");
  if (has_statistics_) {
    BagSummary summary;
    summary.format = format;
    summary.files = {file_.path()};
    summary.compression = compressions_.empty() ? "none" : absl::StrJoin(compressions_, ", ");
    summary.messages = CountFrom(stat_messages_);
    summary.start_ns = stat_start_;
    summary.end_ns = stat_end_;
    summary.topics = TopicRows(stat_counts_);
    return summary;
  }
  if (absl::Status status = EnsureTable(); !status.ok()) return status;
  return SummaryFromTable(format, compressions_.empty() ? "none" : absl::StrJoin(compressions_, ", "));
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenMcapFile(RandomFile file, std::string format) {
  auto bag = std::make_unique<McapFile>(std::move(file), std::move(format));
  if (absl::Status status = bag->Open(); !status.ok()) return status;
  return std::unique_ptr<BagReader>(std::move(bag));
}

}  // namespace waymark::bags
