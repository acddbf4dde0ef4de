#ifndef WAYMARK_CLIENT_COMMON_WRITE_FILE_H_
#define WAYMARK_CLIENT_COMMON_WRITE_FILE_H_

#include <filesystem>
#include <string_view>

#include "absl/status/status.h"

namespace waymark::cli {

// Writes `bytes` to `path` unchanged (binary), replacing the file. PERMISSION_DENIED if it cannot
// be opened, DATA_LOSS if writing fails (a full disk).
absl::Status WriteFileBytes(const std::filesystem::path& path, std::string_view bytes);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_WRITE_FILE_H_
