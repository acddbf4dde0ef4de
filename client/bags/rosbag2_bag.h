#ifndef WAYMARK_CLIENT_BAGS_ROSBAG2_BAG_H_
#define WAYMARK_CLIENT_BAGS_ROSBAG2_BAG_H_

// A rosbag2 bag: a folder with metadata.yaml and one or several storage files (split bags), or a
// storage file alone. The files are read together as one bag: their messages merged in time
// order, topics that several files declare alike (same name, type and encoding) merged into one
// connection. Per-file zstd compression is expanded into a temporary file first (sqlite3 cannot
// read through a compressor); per-message zstd as each message is read.

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"

namespace waymark::bags {

// `path` is a folder, or a metadata yaml file (metadata.yaml or a renamed copy).
absl::StatusOr<std::unique_ptr<BagReader>> OpenRosbag2(const std::string& path);

// One .db3 or .mcap storage file; its folder's metadata.yaml is used when it lists the file.
absl::StatusOr<std::unique_ptr<BagReader>> OpenRosbag2File(const std::string& path, bool mcap);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_ROSBAG2_BAG_H_
