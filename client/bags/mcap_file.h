#ifndef WAYMARK_CLIENT_BAGS_MCAP_FILE_H_
#define WAYMARK_CLIENT_BAGS_MCAP_FILE_H_

// MCAP (https://mcap.dev/spec): magic, header, schema, channel and message records, chunks
// (uncompressed, lz4 frames or zstd; their CRC checked when set), and the summary section
// (schemas, channels, statistics, chunk indexes) when the file has one, which is all `bag info`
// reads. Without a summary (a recording cut short) the data section is walked record by record.
// Messages in the `ros1` and `cdr` encodings are marked so for the decoders; others (json,
// protobuf, ...) are listed but never decoded.

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"
#include "client/bags/random_file.h"

namespace waymark::bags {

inline constexpr char kMcapMagic[] = "\x89MCAP0\r\n";  // 8 bytes

// `format` names the container in Summary() ("MCAP", or "rosbag2 mcap" in a rosbag2 folder).
absl::StatusOr<std::unique_ptr<BagReader>> OpenMcapFile(RandomFile file, std::string format = "MCAP");

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_MCAP_FILE_H_
