#ifndef WAYMARK_CLIENT_BAGS_ROSBAG2_METADATA_H_
#define WAYMARK_CLIENT_BAGS_ROSBAG2_METADATA_H_

// A rosbag2 folder's metadata.yaml: which files hold the bag (split bags list several), their
// storage (sqlite3 or mcap), and how they are compressed (compression_format zstd, mode FILE: each
// file is compressed whole; MESSAGE: each message's data is). The topics and counts it lists are
// not used: the files themselves are the truth, and `bag info` counts from them.

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::bags {

struct Rosbag2Metadata {
  int version = 0;
  std::string storage_identifier;        // "sqlite3", "mcap"
  std::vector<std::string> files;        // absolute paths, in the order listed
  std::string compression_format;        // "" or "zstd"
  std::string compression_mode;          // "", "FILE", "MESSAGE"
  int64_t message_count = 0;             // as the metadata says
};

// Reads `yaml_path` (metadata.yaml or a renamed copy); file paths are resolved against the yaml's
// folder, falling back to its parent (older rosbag2 wrote paths that start with the bag's folder
// name) and to the bare file name. INVALID_ARGUMENT naming the key when the document is not
// rosbag2 metadata.
absl::StatusOr<Rosbag2Metadata> ReadRosbag2Metadata(const std::string& yaml_path);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_ROSBAG2_METADATA_H_
