#include "storage/store_util.h"

#include <filesystem>
#include <system_error>

namespace waymark::storage {

absl::Status EnsureParentDirectory(const std::string& file_path) {
  if (file_path.empty() || file_path == ":memory:") return absl::OkStatus();
  const std::filesystem::path parent = std::filesystem::path(file_path).parent_path();
  if (parent.empty()) return absl::OkStatus();
  std::error_code error;
  std::filesystem::create_directories(parent, error);
  if (error) {
    return absl::InternalError(absl::StrCat("cannot create directory \"", parent.string(),
                                            "\" for the database: ", error.message()));
  }
  return absl::OkStatus();
}

}  // namespace waymark::storage
