// OpenBag: which reader a path needs, decided by the file's first bytes (a folder is a rosbag2
// bag), so that a renamed file still opens and a file that is not a bag is said to be one.
#include <filesystem>
#include <string_view>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/bags/bag_reader.h"
#include "client/bags/byte_cursor.h"
#include "client/bags/mcap_file.h"
#include "client/bags/random_file.h"
#include "client/bags/ros1_bag.h"
#include "client/bags/rosbag2_bag.h"

namespace waymark::bags {
namespace {

// The first bytes, printable, for an error message.
std::string Shown(std::string_view bytes) {
  std::string out;
  for (const char c : bytes.substr(0, 16)) {
    out += absl::ascii_isprint(static_cast<unsigned char>(c)) ? c : '.';
  }
  return out;
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenBag(const std::string& path) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (!std::filesystem::exists(status)) return absl::NotFoundError(absl::StrCat(path, ": no such file or folder"));
  if (std::filesystem::is_directory(status)) return OpenRosbag2(path);

  absl::StatusOr<RandomFile> file = RandomFile::Open(path);
  if (!file.ok()) return file.status();
  if (file->size() == 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": empty file (0 bytes), not a bag"));
  }
  absl::StatusOr<std::string> head = file->ReadUpTo(0, 64);
  if (!head.ok()) return head.status();
  const std::string_view start = *head;
  if (HasPrefix(start, kRos1Magic)) return OpenRos1Bag(*std::move(file));
  if (HasPrefix(start, kRos1OldMagic)) {
    return absl::FailedPreconditionError(absl::StrCat(
        path, ": a ROS bag in the old format #ROSRECORD V1.2; this reader reads format 2.0 "
              "(#ROSBAG V2.0). Rewrite it as 2.0 with a ROS 1 install's rosbag first, e.g. "
              "`rosbag fix OLD.bag NEW.bag` (or `rosbag filter OLD.bag NEW.bag True`)"));
  }
  if (HasPrefix(start, "#ROSBAG V") || HasPrefix(start, "#ROSRECORD V")) {
    const size_t end = start.find('\n');
    return absl::UnimplementedError(absl::StrCat(
        path, ": ROS bag version \"", std::string(start.substr(0, std::min<size_t>(end, 24))),
        "\" is not read; this reader reads format 2.0 (#ROSBAG V2.0)"));
  }
  if (HasPrefix(start, std::string_view(kMcapMagic, 8))) {
    return OpenMcapFile(*std::move(file), "MCAP");
  }
  if (HasPrefix(start, std::string_view("SQLite format 3\0", 16))) {
    return OpenRosbag2File(path, /*mcap=*/false);
  }
  if (start.find("rosbag2_bagfile_information") != std::string_view::npos) return OpenRosbag2(path);
  if (start.size() < 8 && (std::string_view(kMcapMagic, 8).substr(0, start.size()) == start ||
                           std::string_view(kRos1Magic).substr(0, start.size()) == start)) {
    return absl::DataLossError(absl::StrCat(path, ": cut off after ", start.size(),
                                            " bytes, before the end of its first line"));
  }
  return absl::InvalidArgumentError(absl::StrCat(
      path, ": not a bag: it starts with \"", Shown(start),
      "\", not #ROSBAG V2.0 (ROS 1), the MCAP magic, or SQLite format 3 (rosbag2); a rosbag2 "
      "bag is opened by its folder or metadata.yaml"));
}

}  // namespace waymark::bags
