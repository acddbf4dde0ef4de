#ifndef WAYMARK_CLIENT_BAGS_DECOMPRESS_H_
#define WAYMARK_CLIENT_BAGS_DECOMPRESS_H_

// The compressions bags use, through Debian's libraries: bz2 (libbz2; ROS 1 chunks), lz4 in the
// LZ4 *frame* format (liblz4's lz4frame; both ROS 1's roslz4 and MCAP write frames, not raw
// blocks) and zstd (libzstd; MCAP chunks, rosbag2 files and messages).
// Output grows as the codec produces it and stops at `expected_size` (what the container
// declares), so a lying size field costs no allocation beyond what the data really expands to,
// and a stream that expands past its declared size (a bomb or a damaged chunk) is an error.

#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace waymark::bags {

enum class Compression { kNone, kBz2, kLz4, kZstd };

// "none"/"" -> kNone, "bz2", "lz4", "zstd"; anything else is UNIMPLEMENTED naming it.
absl::StatusOr<Compression> ParseCompression(std::string_view name);
const char* CompressionName(Compression compression);

// The largest chunk or message the readers expand (a bigger declared size is refused up front).
constexpr uint64_t kMaxExpandedBytes = uint64_t{2} << 30;

// Decompresses `input` that must expand to exactly `expected_size` bytes (when `exact`) or to at
// most `expected_size` bytes. DATA_LOSS when the stream is damaged or truncated or its size is
// not the declared one. `cut_ok`: the input is a stream cut short by the end of a file, and what
// it expands to up to the cut is the answer (damage is still an error).
absl::StatusOr<std::string> Decompress(Compression compression, std::string_view input,
                                       uint64_t expected_size, bool exact = true,
                                       bool cut_ok = false);

// zstd with no declared size (a rosbag2 message): at most `limit` bytes.
absl::StatusOr<std::string> DecompressZstdUpTo(std::string_view input, uint64_t limit);

// A whole zstd-compressed file (rosbag2's per-file compression) into `to_path`, streamed.
absl::Status DecompressZstdFile(const std::string& from_path, const std::string& to_path);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_DECOMPRESS_H_
