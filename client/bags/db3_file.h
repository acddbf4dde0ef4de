#ifndef WAYMARK_CLIENT_BAGS_DB3_FILE_H_
#define WAYMARK_CLIENT_BAGS_DB3_FILE_H_

// One rosbag2 sqlite3 storage file (`.db3`), read-only through Debian's libsqlite3. Both schema
// generations are read: the old one (topics without offered_qos_profiles or with it, no schema
// table) and the current one (schema, metadata and message_definitions tables,
// type_description_hash); columns are looked up, not assumed, as rosbag2's own reader does.
// Messages come in timestamp order (ties by row id), through the timestamp index rosbag2 creates.

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"

namespace waymark::bags {

struct Db3Options {
  // rosbag2 compression_mode MESSAGE with compression_format zstd: each row's data is a zstd frame.
  bool zstd_messages = false;
  // No metadata.yaml said: a row whose data starts with the zstd magic is expanded (a CDR message
  // starts with its encapsulation header, 00 00 or 00 01, never with 28 b5 2f fd).
  bool detect_zstd = false;
};

absl::StatusOr<std::unique_ptr<BagReader>> OpenDb3File(const std::string& path, Db3Options options);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_DB3_FILE_H_
