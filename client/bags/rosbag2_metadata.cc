#include "client/bags/rosbag2_metadata.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "absl/strings/str_cat.h"

// yaml-cpp (Debian's libyaml-cpp-dev), not a hand-written reader: metadata.yaml is machine-written
// YAML with nested maps, block and flow lists and multi-line quoted strings (the QoS profiles), in
// whatever key order the writer chose; a small reader of our own would be a second YAML parser to
// get wrong.

namespace waymark::bags {
namespace {

namespace fs = std::filesystem;

std::string Resolve(const fs::path& folder, const std::string& relative) {
  const fs::path listed(relative);
  // Never the throwing overloads: a listed name may be anything (too long, say).
  std::error_code absolute_error;
  if (listed.is_absolute() && fs::exists(listed, absolute_error)) return listed.string();
  for (const fs::path& candidate :
       {folder / listed, folder.parent_path() / listed, folder / listed.filename()}) {
    std::error_code error;
    if (fs::exists(candidate, error)) return candidate.lexically_normal().string();
  }
  return (folder / listed).lexically_normal().string();  // missing: the open names it
}

}  // namespace

absl::StatusOr<Rosbag2Metadata> ReadRosbag2Metadata(const std::string& yaml_path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(yaml_path);
  } catch (const YAML::BadFile&) {
    return absl::NotFoundError(absl::StrCat(yaml_path, ": cannot be read"));
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(yaml_path, ": not valid YAML: ", e.what()));
  }
  try {
    const YAML::Node info = root.IsMap() ? root["rosbag2_bagfile_information"] : YAML::Node();
    if (!info || !info.IsMap()) {
      return absl::InvalidArgumentError(
          absl::StrCat(yaml_path, ": not rosbag2 metadata (no rosbag2_bagfile_information map)"));
    }
    Rosbag2Metadata metadata;
    if (info["version"]) metadata.version = info["version"].as<int>();
    if (info["storage_identifier"]) {
      metadata.storage_identifier = info["storage_identifier"].as<std::string>();
    }
    if (info["compression_format"]) {
      metadata.compression_format = info["compression_format"].as<std::string>();
    }
    if (info["compression_mode"]) metadata.compression_mode = info["compression_mode"].as<std::string>();
    if (info["message_count"]) metadata.message_count = info["message_count"].as<int64_t>();
    const fs::path folder = fs::path(yaml_path).parent_path();
    const YAML::Node paths = info["relative_file_paths"];
    if (!paths || !paths.IsSequence() || paths.size() == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(yaml_path, ": rosbag2 metadata without relative_file_paths"));
    }
    for (const YAML::Node& path : paths) {
      metadata.files.push_back(Resolve(folder, path.as<std::string>()));
    }
    return metadata;
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(yaml_path, ": unexpected rosbag2 metadata: ", e.what()));
  }
}

}  // namespace waymark::bags
