#ifndef WAYMARK_CLIENT_BAGS_CHUNKED_READER_H_
#define WAYMARK_CLIENT_BAGS_CHUNKED_READER_H_

// What the ROS 1 and MCAP readers share: a file of (possibly compressed) chunks, a table of where
// each message is (its time, chunk and offset in the expanded chunk), sorted by log time, and a
// small cache of expanded chunks. Messages come out in time order even when chunks overlap or
// are out of order (rosbag.js's unsorted fixture), at the cost of expanding a chunk again when
// the order jumps between more chunks than the cache holds.

#include <cstdint>
#include <limits>
#include <list>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"
#include "client/bags/decompress.h"
#include "client/bags/random_file.h"

namespace waymark::bags {

// Where a chunk's records are in the file and how they are stored.
struct ChunkRef {
  uint64_t data_offset = 0;    // first byte of the stored (compressed) records
  uint64_t data_length = 0;    // stored bytes
  Compression compression = Compression::kNone;
  uint64_t expanded_size = 0;  // declared size once expanded
  bool cut = false;            // cut short by the end of the file: what it holds up to the cut
};

// One message: where it is and when it was logged.
struct MessageRef {
  int64_t time_ns = 0;
  uint32_t chunk = 0;
  uint64_t offset = 0;  // of the message's record in the expanded chunk
  int connection = 0;
};

class ChunkedReader : public BagReader {
 public:
  explicit ChunkedReader(RandomFile file) : file_(std::move(file)) {}

  const std::vector<BagConnection>& connections() const override { return connections_; }
  absl::StatusOr<bool> Next(BagMessage* message) override;
  void Select(const std::vector<int>& wanted) override;
  const std::vector<std::string>& warnings() const override { return warnings_; }

 protected:
  // Fills chunks_ and messages_ (in any order) when they are not yet known; called once, before
  // the first message or a summary that needs the table.
  virtual absl::Status BuildTable() = 0;
  // The message record at `offset` of an expanded chunk: its serialized payload.
  virtual absl::StatusOr<std::string_view> MessageAt(std::string_view chunk, uint64_t offset) const = 0;

  absl::Status EnsureTable();
  // Counts, times and topics from the message table (formats without an index of counts).
  BagSummary SummaryFromTable(std::string format, std::string compression) const;
  // Topic rows from per-connection counts, merged by topic.
  std::vector<BagTopicSummary> TopicRows(const std::map<int, int64_t>& counts) const;
  // A connection by id (nullptr when the file never declared it).
  const BagConnection* FindConnection(int id) const;
  void AddConnection(BagConnection connection);
  void Warn(std::string warning);
  absl::StatusOr<std::string> ExpandChunk(const ChunkRef& chunk) const;

  RandomFile file_;
  std::vector<BagConnection> connections_;
  std::map<int, size_t> connection_index_;
  std::vector<ChunkRef> chunks_;
  std::vector<MessageRef> messages_;
  std::vector<std::string> warnings_;
  bool table_built_ = false;

 private:
  // The expanded chunk, from the cache or the file; nullptr after a warning when it is unreadable.
  const std::string* LoadChunk(uint32_t index);

  size_t cursor_ = 0;
  std::set<int> wanted_;
  std::set<uint32_t> bad_chunks_;
  std::list<std::pair<uint32_t, std::string>> cache_;  // most recent first
  std::set<std::string> warned_;
};

// Message counts a file claims (MCAP's statistics record: uint64 per channel) as int64, and their
// sums, held at the int64 limits instead of overflowing: a damaged file may claim 2^64 messages.
inline int64_t CountFrom(uint64_t claimed) {
  constexpr uint64_t kMax = static_cast<uint64_t>(std::numeric_limits<int64_t>::max());
  return static_cast<int64_t>(claimed > kMax ? kMax : claimed);
}
inline int64_t AddCounts(int64_t a, int64_t b) {
  int64_t sum = 0;
  if (!__builtin_add_overflow(a, b, &sum)) return sum;
  return b > 0 ? std::numeric_limits<int64_t>::max() : std::numeric_limits<int64_t>::min();
}

// "sensor_msgs/msg/LaserScan" -> "sensor_msgs/LaserScan"; other names unchanged.
std::string NormalizeType(std::string_view raw_type);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_CHUNKED_READER_H_
