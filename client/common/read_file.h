#ifndef WAYMARK_CLIENT_COMMON_READ_FILE_H_
#define WAYMARK_CLIENT_COMMON_READ_FILE_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"

namespace waymark::cli {

// The file's bytes, unchanged (images are sent as encoded; the server decodes and resizes).
// NOT_FOUND if it does not exist, PERMISSION_DENIED if it cannot be read.
absl::StatusOr<std::string> ReadFileBytes(const std::filesystem::path& path);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_READ_FILE_H_
