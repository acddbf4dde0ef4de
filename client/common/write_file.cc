#include "client/common/write_file.h"

#include <fstream>

namespace waymark::cli {

absl::Status WriteFileBytes(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return absl::PermissionDeniedError("cannot write '" + path.string() + "'");
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return absl::DataLossError("writing '" + path.string() + "' failed");
  return absl::OkStatus();
}

}  // namespace waymark::cli
