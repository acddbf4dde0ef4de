#include "client/bags/chunked_reader.h"

#include <algorithm>
#include <tuple>

#include "absl/strings/str_cat.h"

namespace waymark::bags {
namespace {

// Expanded chunks kept: ROS 1 chunks are ~768 KiB and MCAP's a few MiB, so a handful covers
// chunks that overlap in time without holding much of the file. Bounded in bytes too: a chunk
// may declare up to kMaxExpandedBytes (2 GiB), and a few KB of zstd can expand to hundreds of MB,
// so eight of them would hold gigabytes; the chunk just read is always kept.
constexpr size_t kCachedChunks = 8;
constexpr size_t kCachedBytes = size_t{256} << 20;

}  // namespace

std::string NormalizeType(std::string_view raw_type) {
  const size_t slash = raw_type.find("/msg/");
  if (slash == std::string_view::npos || slash == 0) return std::string(raw_type);
  return std::string(raw_type.substr(0, slash)) + "/" + std::string(raw_type.substr(slash + 5));
}

void ChunkedReader::Warn(std::string warning) {
  // The same problem once, however many messages it touches.
  if (warned_.insert(warning).second) warnings_.push_back(std::move(warning));
}

void ChunkedReader::AddConnection(BagConnection connection) {
  if (connection_index_.count(connection.id)) return;
  connection_index_[connection.id] = connections_.size();
  connections_.push_back(std::move(connection));
}

const BagConnection* ChunkedReader::FindConnection(int id) const {
  auto it = connection_index_.find(id);
  return it == connection_index_.end() ? nullptr : &connections_[it->second];
}

absl::Status ChunkedReader::EnsureTable() {
  if (table_built_) return absl::OkStatus();
  table_built_ = true;
  if (absl::Status status = BuildTable(); !status.ok()) return status;
  std::sort(messages_.begin(), messages_.end(), [](const MessageRef& a, const MessageRef& b) {
    return std::tie(a.time_ns, a.chunk, a.offset) < std::tie(b.time_ns, b.chunk, b.offset);
  });
  return absl::OkStatus();
}

void ChunkedReader::Select(const std::vector<int>& wanted) {
  wanted_ = std::set<int>(wanted.begin(), wanted.end());
}

absl::StatusOr<std::string> ChunkedReader::ExpandChunk(const ChunkRef& chunk) const {
  absl::StatusOr<std::string> stored = file_.Read(chunk.data_offset, chunk.data_length);
  if (!stored.ok()) return stored.status();
  if (chunk.compression == Compression::kNone) return stored;
  return Decompress(chunk.compression, *stored, chunk.expanded_size, !chunk.cut, chunk.cut);
}

const std::string* ChunkedReader::LoadChunk(uint32_t index) {
  for (auto it = cache_.begin(); it != cache_.end(); ++it) {
    if (it->first == index) {
      cache_.splice(cache_.begin(), cache_, it);
      return &cache_.front().second;
    }
  }
  if (bad_chunks_.count(index) || index >= chunks_.size()) return nullptr;
  absl::StatusOr<std::string> expanded = ExpandChunk(chunks_[index]);
  if (!expanded.ok()) {
    bad_chunks_.insert(index);
    Warn(absl::StrCat("chunk at offset ", chunks_[index].data_offset,
                      " could not be read, its messages are skipped: ", expanded.status().message()));
    return nullptr;
  }
  cache_.emplace_front(index, *std::move(expanded));
  size_t bytes = 0;
  for (const auto& [cached, data] : cache_) bytes += data.size();
  while (cache_.size() > 1 && (cache_.size() > kCachedChunks || bytes > kCachedBytes)) {
    bytes -= cache_.back().second.size();
    cache_.pop_back();
  }
  return &cache_.front().second;
}

absl::StatusOr<bool> ChunkedReader::Next(BagMessage* message) {
  if (absl::Status status = EnsureTable(); !status.ok()) return status;
  while (cursor_ < messages_.size()) {
    const MessageRef& ref = messages_[cursor_++];
    if (!wanted_.empty() && !wanted_.count(ref.connection)) continue;
    const std::string* chunk = LoadChunk(ref.chunk);
    if (chunk == nullptr) continue;
    absl::StatusOr<std::string_view> data = MessageAt(*chunk, ref.offset);
    if (!data.ok()) {
      Warn(absl::StrCat("message at offset ", ref.offset, " of the chunk at file offset ",
                        chunks_[ref.chunk].data_offset, " is skipped: ", data.status().message()));
      continue;
    }
    message->connection_id = ref.connection;
    message->log_time_ns = ref.time_ns;
    message->data.assign(data->data(), data->size());
    return true;
  }
  return false;
}

std::vector<BagTopicSummary> ChunkedReader::TopicRows(const std::map<int, int64_t>& counts) const {
  std::map<std::string, BagTopicSummary> by_topic;
  for (const BagConnection& connection : connections_) {
    BagTopicSummary& row = by_topic[connection.topic];
    row.topic = connection.topic;
    if (row.type.empty()) row.type = connection.type;
    auto it = counts.find(connection.id);
    if (it != counts.end()) row.messages = AddCounts(row.messages, it->second);
  }
  std::vector<BagTopicSummary> rows;
  for (auto& [topic, row] : by_topic) rows.push_back(std::move(row));
  return rows;
}

BagSummary ChunkedReader::SummaryFromTable(std::string format, std::string compression) const {
  BagSummary summary;
  summary.format = std::move(format);
  summary.compression = std::move(compression);
  summary.files = {file_.path()};
  std::map<int, int64_t> counts;
  for (const MessageRef& ref : messages_) {
    ++counts[ref.connection];
    if (summary.messages == 0 || ref.time_ns < summary.start_ns) summary.start_ns = ref.time_ns;
    if (summary.messages == 0 || ref.time_ns > summary.end_ns) summary.end_ns = ref.time_ns;
    ++summary.messages;
  }
  summary.topics = TopicRows(counts);
  return summary;
}

}  // namespace waymark::bags
