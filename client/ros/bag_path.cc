#include "client/ros/bag_path.h"

#include <filesystem>
#include <fstream>
#include <string_view>

namespace waymark::ros {

bool LooksLikeBag(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    // A rosbag2 folder, not an image sequence: metadata.yaml or a storage file.
    for (const auto& entry : std::filesystem::directory_iterator(path, ec)) {
      const std::string name = entry.path().filename().string();
      const std::string ext = entry.path().extension().string();
      if (name == "metadata.yaml" || ext == ".db3" || ext == ".mcap") return true;
    }
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  char head[16] = {};
  in.read(head, sizeof(head));
  const std::string_view start(head, static_cast<size_t>(in.gcount()));
  for (std::string_view magic : {std::string_view("#ROSBAG"), std::string_view("#ROSRECORD"),
                                 std::string_view("\x89MCAP"),
                                 std::string_view("SQLite format 3")}) {
    if (start.substr(0, magic.size()) == magic) return true;
  }
  return false;
}

}  // namespace waymark::ros
