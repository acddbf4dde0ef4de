#include "client/bags/ros1_bag.h"

#include <cstring>
#include <map>
#include <set>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/bags/byte_cursor.h"
#include "client/bags/chunked_reader.h"

namespace waymark::bags {
namespace {

constexpr uint8_t kOpMessageData = 0x02;
constexpr uint8_t kOpBagHeader = 0x03;
constexpr uint8_t kOpIndexData = 0x04;
constexpr uint8_t kOpChunk = 0x05;
constexpr uint8_t kOpChunkInfo = 0x06;
constexpr uint8_t kOpConnection = 0x07;

// Record headers are a few hundred bytes; a connection header with its message definition a few
// tens of KiB. Anything claiming more than this is damage, not a header.
constexpr uint32_t kMaxHeaderBytes = 16u << 20;

// A record header's name=value fields.
using Fields = std::map<std::string, std::string_view, std::less<>>;

bool ParseFields(std::string_view header, Fields* fields) {
  ByteCursor cursor(header);
  while (!cursor.empty()) {
    std::string_view field;
    if (!cursor.Prefixed<uint32_t>(&field)) return false;
    const size_t equals = field.find('=');
    if (equals == std::string_view::npos) return false;
    (*fields)[std::string(field.substr(0, equals))] = field.substr(equals + 1);
  }
  return true;
}

template <typename T>
bool Field(const Fields& fields, std::string_view name, T* value) {
  auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != sizeof(T)) return false;
  std::memcpy(value, it->second.data(), sizeof(T));
  return true;
}

uint8_t Op(const Fields& fields) {
  uint8_t op = 0;
  return Field(fields, "op", &op) ? op : 0;
}

int64_t TimeNs(uint64_t ros_time) {
  // sec in the low 32 bits, nsec in the high 32 (two little-endian uint32, sec first).
  return int64_t{static_cast<uint32_t>(ros_time)} * 1000000000 + (ros_time >> 32);
}

// A record inside a buffer (an expanded chunk): header fields and data.
struct Record {
  Fields fields;
  std::string_view data;
};

absl::StatusOr<Record> ParseRecord(ByteCursor* cursor) {
  Record record;
  std::string_view header;
  if (!cursor->Prefixed<uint32_t>(&header)) return absl::DataLossError("record header cut short");
  if (!ParseFields(header, &record.fields)) return absl::DataLossError("malformed record header");
  if (!cursor->Prefixed<uint32_t>(&record.data)) return absl::DataLossError("record data cut short");
  return record;
}

BagConnection ConnectionFrom(const Fields& header, std::string_view data) {
  BagConnection connection;
  uint32_t id = 0;
  Field(header, "conn", &id);
  connection.id = static_cast<int>(id);
  Fields details;
  ParseFields(data, &details);  // a damaged connection header leaves the fields empty
  auto text = [&](std::string_view name) {
    auto it = details.find(name);
    return it == details.end() ? std::string() : std::string(it->second);
  };
  auto topic = header.find("topic");
  connection.topic = topic != header.end() ? std::string(topic->second) : text("topic");
  connection.raw_type = text("type");
  connection.type = NormalizeType(connection.raw_type);
  connection.encoding = MessageEncoding::kRos1;
  connection.encoding_name = "ros1";
  connection.definition = text("message_definition");
  connection.md5sum = text("md5sum");
  connection.callerid = text("callerid");
  return connection;
}

class Ros1Bag final : public ChunkedReader {
 public:
  explicit Ros1Bag(RandomFile file) : ChunkedReader(std::move(file)) {}

  absl::Status Open();
  absl::StatusOr<BagSummary> Summary() override;

 protected:
  absl::Status BuildTable() override;
  absl::StatusOr<std::string_view> MessageAt(std::string_view chunk, uint64_t offset) const override;

 private:
  struct ChunkInfo {
    uint64_t chunk_pos = 0;
    int64_t start_ns = 0;
    int64_t end_ns = 0;
    std::map<int, int64_t> counts;
  };
  // A record's header at a file offset; the data's offset and length (not read).
  struct FileRecord {
    Fields fields;
    std::string header_bytes;  // fields point into this
    uint64_t data_offset = 0;
    uint64_t data_length = 0;
    uint64_t end = 0;
  };
  absl::StatusOr<FileRecord> ReadRecordAt(uint64_t offset) const;
  absl::Status ReadIndex(uint64_t index_pos, uint32_t conn_count, uint32_t chunk_count);
  absl::Status ChunkAt(uint64_t chunk_pos, ChunkRef* chunk, uint64_t* end) const;
  void Scan(uint64_t from);
  void ScanChunk(uint32_t index, std::string_view expanded);

  std::vector<ChunkInfo> chunk_infos_;
  bool indexed_ = false;
  std::set<std::string> compressions_;
};

absl::StatusOr<Ros1Bag::FileRecord> Ros1Bag::ReadRecordAt(uint64_t offset) const {
  FileRecord record;
  absl::StatusOr<std::string> length = file_.Read(offset, 4);
  if (!length.ok()) return length.status();
  uint32_t header_length = 0;
  std::memcpy(&header_length, length->data(), 4);
  if (header_length > kMaxHeaderBytes) {
    return absl::DataLossError(absl::StrCat("record at offset ", offset, " claims a header of ",
                                            header_length, " bytes"));
  }
  absl::StatusOr<std::string> header = file_.Read(offset + 4, uint64_t{header_length} + 4);
  if (!header.ok()) return header.status();
  uint32_t data_length = 0;
  std::memcpy(&data_length, header->data() + header_length, 4);
  header->resize(header_length);
  record.header_bytes = *std::move(header);
  if (!ParseFields(record.header_bytes, &record.fields)) {
    return absl::DataLossError(absl::StrCat("malformed record header at offset ", offset));
  }
  record.data_offset = offset + 8 + header_length;
  record.data_length = data_length;
  record.end = record.data_offset + data_length;
  if (record.end > file_.size()) {
    return absl::OutOfRangeError(absl::StrCat("record at offset ", offset, " claims ", data_length,
                                              " bytes of data; the file ends ",
                                              file_.size() - record.data_offset, " bytes later"));
  }
  return record;
}

absl::Status Ros1Bag::Open() {
  const uint64_t header_at = std::strlen(kRos1Magic);
  absl::StatusOr<FileRecord> header = ReadRecordAt(header_at);
  if (!header.ok() || Op(header->fields) != kOpBagHeader) {
    return absl::DataLossError(absl::StrCat(
        file_.path(), ": ROS bag V2.0 without a readable bag header record",
        header.ok() ? "" : absl::StrCat(" (", header.status().message(), ")")));
  }
  uint64_t index_pos = 0;
  uint32_t conn_count = 0;
  uint32_t chunk_count = 0;
  Field(header->fields, "index_pos", &index_pos);
  Field(header->fields, "conn_count", &conn_count);
  Field(header->fields, "chunk_count", &chunk_count);
  if (index_pos == 0) {
    Warn("the bag has no index (its recording was not closed); read by scanning its records");
  } else if (index_pos < header->end || index_pos > file_.size()) {
    Warn(absl::StrCat("the bag's index is at offset ", index_pos, ", outside the file's ",
                      file_.size(), " bytes (a truncated file?); read by scanning its records"));
  } else if (absl::Status status = ReadIndex(index_pos, conn_count, chunk_count); !status.ok()) {
    Warn(absl::StrCat("the bag's index is unreadable (", status.message(),
                      "); read by scanning its records"));
  } else {
    indexed_ = true;
    return absl::OkStatus();
  }
  connections_.clear();
  connection_index_.clear();
  chunk_infos_.clear();
  Scan(header->end);
  return EnsureTable();  // BuildTable has nothing left to add; this sorts what the scan found
}

absl::Status Ros1Bag::ReadIndex(uint64_t index_pos, uint32_t conn_count, uint32_t chunk_count) {
  uint64_t offset = index_pos;
  while (offset < file_.size()) {
    absl::StatusOr<FileRecord> record = ReadRecordAt(offset);
    if (!record.ok()) return record.status();
    const uint8_t op = Op(record->fields);
    if (op == kOpConnection) {
      absl::StatusOr<std::string> data = file_.Read(record->data_offset, record->data_length);
      if (!data.ok()) return data.status();
      AddConnection(ConnectionFrom(record->fields, *data));
    } else if (op == kOpChunkInfo) {
      ChunkInfo info;
      uint32_t version = 0;
      uint64_t start = 0, end = 0;
      uint32_t count = 0;
      if (!Field(record->fields, "ver", &version) || version != 1 ||
          !Field(record->fields, "chunk_pos", &info.chunk_pos) ||
          !Field(record->fields, "start_time", &start) || !Field(record->fields, "end_time", &end) ||
          !Field(record->fields, "count", &count)) {
        return absl::DataLossError(absl::StrCat("malformed chunk info record at offset ", offset));
      }
      info.start_ns = TimeNs(start);
      info.end_ns = TimeNs(end);
      if (uint64_t{count} * 8 > record->data_length) {
        return absl::DataLossError(absl::StrCat("chunk info at offset ", offset, " is cut short"));
      }
      absl::StatusOr<std::string> data = file_.Read(record->data_offset, record->data_length);
      if (!data.ok()) return data.status();
      ByteCursor cursor(*data);
      for (uint32_t i = 0; i < count; ++i) {
        uint32_t connection = 0, messages = 0;
        cursor.Read(&connection);
        cursor.Read(&messages);
        info.counts[static_cast<int>(connection)] += messages;
      }
      chunk_infos_.push_back(std::move(info));
    } else {
      return absl::DataLossError(absl::StrCat("unexpected record (op ", int{op},
                                              ") in the index at offset ", offset));
    }
    offset = record->end;
  }
  if (connections_.size() != conn_count || chunk_infos_.size() != chunk_count) {
    return absl::DataLossError(absl::StrCat("the index lists ", connections_.size(), " of ",
                                            conn_count, " connections and ", chunk_infos_.size(),
                                            " of ", chunk_count, " chunks"));
  }
  return absl::OkStatus();
}

absl::Status Ros1Bag::ChunkAt(uint64_t chunk_pos, ChunkRef* chunk, uint64_t* end) const {
  absl::StatusOr<FileRecord> record = ReadRecordAt(chunk_pos);
  if (!record.ok()) return record.status();
  if (Op(record->fields) != kOpChunk) {
    return absl::DataLossError(absl::StrCat("no chunk record at offset ", chunk_pos));
  }
  auto compression = record->fields.find("compression");
  absl::StatusOr<Compression> codec =
      ParseCompression(compression == record->fields.end() ? "" : compression->second);
  if (!codec.ok()) {
    return absl::UnimplementedError(absl::StrCat("chunk at offset ", chunk_pos, ": ", codec.status().message()));
  }
  uint32_t size = 0;
  Field(record->fields, "size", &size);
  chunk->data_offset = record->data_offset;
  chunk->data_length = record->data_length;
  chunk->compression = *codec;
  chunk->expanded_size = *codec == Compression::kNone ? record->data_length : size;
  *end = record->end;
  return absl::OkStatus();
}

absl::Status Ros1Bag::BuildTable() {
  if (!indexed_) return absl::OkStatus();  // the scan at open filled the table
  // The index data records after each chunk: time and offset of each message, per connection.
  for (const ChunkInfo& info : chunk_infos_) {
    ChunkRef chunk;
    uint64_t offset = 0;
    if (absl::Status status = ChunkAt(info.chunk_pos, &chunk, &offset); !status.ok()) {
      Warn(absl::StrCat("chunk at offset ", info.chunk_pos, " is skipped: ", status.message()));
      continue;
    }
    compressions_.insert(CompressionName(chunk.compression));
    const uint32_t index = static_cast<uint32_t>(chunks_.size());
    chunks_.push_back(chunk);
    for (size_t i = 0; i < info.counts.size(); ++i) {
      absl::StatusOr<FileRecord> record = ReadRecordAt(offset);
      if (!record.ok() || Op(record->fields) != kOpIndexData) {
        Warn(absl::StrCat("index data after the chunk at offset ", info.chunk_pos,
                          " is missing or damaged; some of its messages are skipped"));
        break;
      }
      offset = record->end;
      uint32_t connection = 0, count = 0;
      Field(record->fields, "conn", &connection);
      Field(record->fields, "count", &count);
      if (uint64_t{count} * 12 > record->data_length) count = record->data_length / 12;
      absl::StatusOr<std::string> data = file_.Read(record->data_offset, uint64_t{count} * 12);
      if (!data.ok()) return data.status();
      ByteCursor cursor(*data);
      for (uint32_t m = 0; m < count; ++m) {
        uint64_t time = 0;
        uint32_t at = 0;
        cursor.Read(&time);
        cursor.Read(&at);
        messages_.push_back({TimeNs(time), index, at, static_cast<int>(connection)});
      }
    }
  }
  return absl::OkStatus();
}

void Ros1Bag::ScanChunk(uint32_t index, std::string_view expanded) {
  ByteCursor cursor(expanded);
  while (!cursor.empty()) {
    const uint64_t at = cursor.position();
    absl::StatusOr<Record> record = ParseRecord(&cursor);
    if (!record.ok()) {
      Warn(absl::StrCat("the chunk at offset ", chunks_[index].data_offset, " ends in a cut record (",
                        record.status().message(), "); the messages before it are kept"));
      return;
    }
    const uint8_t op = Op(record->fields);
    if (op == kOpConnection) {
      AddConnection(ConnectionFrom(record->fields, record->data));
    } else if (op == kOpMessageData) {
      uint32_t connection = 0;
      uint64_t time = 0;
      if (Field(record->fields, "conn", &connection) && Field(record->fields, "time", &time)) {
        messages_.push_back({TimeNs(time), index, at, static_cast<int>(connection)});
      }
    }
  }
}

void Ros1Bag::Scan(uint64_t from) {
  uint64_t offset = from;
  while (offset < file_.size()) {
    absl::StatusOr<FileRecord> record = ReadRecordAt(offset);
    if (!record.ok()) {
      // A chunk cut by the end of the file: what it holds (uncompressed) is still readable.
      if (record.status().code() == absl::StatusCode::kOutOfRange) {
        absl::StatusOr<std::string> head = file_.ReadUpTo(offset, 4);
        uint32_t header_length = 0;
        if (head.ok() && head->size() == 4) std::memcpy(&header_length, head->data(), 4);
        absl::StatusOr<std::string> header = file_.ReadUpTo(offset + 4, header_length);
        Fields fields;
        if (header_length <= kMaxHeaderBytes && header.ok() && header->size() == header_length &&
            ParseFields(*header, &fields) && Op(fields) == kOpChunk) {
          auto compression = fields.find("compression");
          absl::StatusOr<Compression> codec =
              ParseCompression(compression == fields.end() ? "" : compression->second);
          uint32_t size = 0;
          Field(fields, "size", &size);
          const uint64_t data_offset = offset + 8 + header_length;
          if (codec.ok() && data_offset < file_.size()) {
            const uint32_t index = static_cast<uint32_t>(chunks_.size());
            const uint64_t held = file_.size() - data_offset;
            chunks_.push_back({data_offset, held, *codec, *codec == Compression::kNone ? held : size,
                               /*cut=*/true});
            compressions_.insert(CompressionName(*codec));
            if (absl::StatusOr<std::string> data = ExpandChunk(chunks_.back()); data.ok()) {
              ScanChunk(index, *data);
            }
          }
        }
      }
      Warn(absl::StrCat("the bag ends in a cut record at offset ", offset, " (",
                        record.status().message(), "); the messages before it are kept"));
      return;
    }
    const uint8_t op = Op(record->fields);
    if (op == kOpChunk) {
      ChunkRef chunk;
      uint64_t end = 0;
      if (absl::Status status = ChunkAt(offset, &chunk, &end); !status.ok()) {
        Warn(absl::StrCat("chunk at offset ", offset, " is skipped: ", status.message()));
      } else {
        const uint32_t index = static_cast<uint32_t>(chunks_.size());
        chunks_.push_back(chunk);
        compressions_.insert(CompressionName(chunk.compression));
        absl::StatusOr<std::string> expanded = ExpandChunk(chunk);
        if (expanded.ok()) {
          ScanChunk(index, *expanded);
        } else {
          Warn(absl::StrCat("chunk at offset ", offset, " is skipped: ", expanded.status().message()));
        }
      }
    } else if (op == kOpConnection) {
      absl::StatusOr<std::string> data = file_.Read(record->data_offset, record->data_length);
      if (data.ok()) AddConnection(ConnectionFrom(record->fields, *data));
    } else if (op != kOpIndexData && op != kOpChunkInfo && op != kOpBagHeader) {
      Warn(absl::StrCat("record with unknown op ", int{op}, " at offset ", offset, " is skipped"));
    }
    offset = record->end;
  }
}

absl::StatusOr<std::string_view> Ros1Bag::MessageAt(std::string_view chunk, uint64_t offset) const {
  if (offset >= chunk.size()) return absl::DataLossError("offset past the end of its chunk");
  ByteCursor cursor(chunk.substr(offset));
  absl::StatusOr<Record> record = ParseRecord(&cursor);
  if (!record.ok()) return record.status();
  if (Op(record->fields) != kOpMessageData) return absl::DataLossError("no message data record there");
  return record->data;
}

absl::StatusOr<BagSummary> Ros1Bag::Summary() {
  if (!indexed_) {
    return SummaryFromTable("ROS 1 bag v2.0", compressions_.empty()
                                                  ? "none"
                                                  : absl::StrJoin(compressions_, ", "));
  }
  // From the index alone: chunk infos hold the counts and times; chunk headers the compression.
  BagSummary summary;
  summary.format = "ROS 1 bag v2.0";
  summary.files = {file_.path()};
  std::map<int, int64_t> counts;
  std::set<std::string> compressions;
  bool first = true;
  for (const ChunkInfo& info : chunk_infos_) {
    for (const auto& [connection, count] : info.counts) {
      counts[connection] += count;
      summary.messages += count;
    }
    if (first || info.start_ns < summary.start_ns) summary.start_ns = info.start_ns;
    if (first || info.end_ns > summary.end_ns) summary.end_ns = info.end_ns;
    first = false;
    ChunkRef chunk;
    uint64_t end = 0;
    if (ChunkAt(info.chunk_pos, &chunk, &end).ok()) {
      compressions.insert(CompressionName(chunk.compression));
    } else {
      compressions.insert("unreadable");
    }
  }
  summary.compression = compressions.empty() ? "none" : absl::StrJoin(compressions, ", ");
  summary.topics = TopicRows(counts);
  return summary;
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenRos1Bag(RandomFile file) {
  auto bag = std::make_unique<Ros1Bag>(std::move(file));
  if (absl::Status status = bag->Open(); !status.ok()) return status;
  return std::unique_ptr<BagReader>(std::move(bag));
}

}  // namespace waymark::bags
