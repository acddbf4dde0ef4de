#include "client/bags/rosbag2_bag.h"

#include <stdlib.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/bags/byte_cursor.h"
#include "client/bags/chunked_reader.h"
#include "client/bags/db3_file.h"
#include "client/bags/decompress.h"
#include "client/bags/mcap_file.h"
#include "client/bags/random_file.h"
#include "client/bags/rosbag2_metadata.h"

namespace waymark::bags {
namespace {

namespace fs = std::filesystem;

// Several storage files read as one bag, merged by log time (ties: the earlier file first).
class MergedBag final : public BagReader {
 public:
  struct Part {
    std::unique_ptr<BagReader> reader;
    std::string path;
    std::map<int, int> to_global;
    BagMessage head;
    bool has_head = false;
    bool done = false;
    bool excluded = false;  // by Select
  };

  MergedBag(std::string format, std::string compression, std::vector<std::string> own_warnings,
            std::vector<std::string> temp_dirs)
      : format_(std::move(format)), compression_(std::move(compression)),
        own_warnings_(std::move(own_warnings)), temp_dirs_(std::move(temp_dirs)) {}
  ~MergedBag() override {
    parts_.clear();  // close the files before removing their temporary copies
    for (const std::string& dir : temp_dirs_) {
      std::error_code error;
      fs::remove_all(dir, error);
    }
  }

  void AddPart(std::unique_ptr<BagReader> reader, std::string path) {
    Part part;
    for (const BagConnection& connection : reader->connections()) {
      const std::string key =
          absl::StrCat(connection.topic, "\n", connection.raw_type, "\n", connection.encoding_name);
      auto [it, added] = global_ids_.emplace(key, static_cast<int>(connections_.size()));
      if (added) {
        BagConnection merged = connection;
        merged.id = it->second;
        connections_.push_back(std::move(merged));
      }
      part.to_global[connection.id] = it->second;
    }
    part.reader = std::move(reader);
    part.path = std::move(path);
    parts_.push_back(std::move(part));
  }

  const std::vector<BagConnection>& connections() const override { return connections_; }

  const std::vector<std::string>& warnings() const override {
    all_warnings_ = own_warnings_;
    for (const Part& part : parts_) {
      for (const std::string& warning : part.reader->warnings()) {
        all_warnings_.push_back(parts_.size() > 1 && !absl::StrContains(warning, part.path)
                                    ? absl::StrCat(part.path, ": ", warning)
                                    : warning);
      }
    }
    return all_warnings_;
  }

  void Select(const std::vector<int>& wanted) override {
    const std::set<int> global(wanted.begin(), wanted.end());
    for (Part& part : parts_) {
      std::vector<int> local;
      for (const auto& [id, global_id] : part.to_global) {
        if (global.count(global_id)) local.push_back(id);
      }
      // A file with none of the wanted topics is not read at all.
      part.excluded = !wanted.empty() && local.empty();
      if (!part.excluded) part.reader->Select(local);
      if (part.has_head &&
          (part.excluded ||
           (!global.empty() && !global.count(part.to_global[part.head.connection_id])))) {
        part.has_head = false;
      }
    }
  }

  absl::StatusOr<bool> Next(BagMessage* message) override {
    Part* best = nullptr;
    for (Part& part : parts_) {
      if (part.excluded) continue;
      if (!part.has_head && !part.done) {
        absl::StatusOr<bool> more = part.reader->Next(&part.head);
        if (!more.ok()) return more.status();
        part.has_head = *more;
        part.done = !*more;
      }
      if (part.has_head && (best == nullptr || part.head.log_time_ns < best->head.log_time_ns)) {
        best = &part;
      }
    }
    if (best == nullptr) return false;
    *message = std::move(best->head);
    message->connection_id = best->to_global[message->connection_id];
    best->has_head = false;
    return true;
  }

  absl::StatusOr<BagSummary> Summary() override {
    BagSummary summary;
    summary.format = format_;
    std::set<std::string> compressions;
    std::map<std::string, BagTopicSummary> rows;
    for (const BagConnection& connection : connections_) {
      rows[connection.topic].topic = connection.topic;
      if (rows[connection.topic].type.empty()) rows[connection.topic].type = connection.type;
    }
    for (Part& part : parts_) {
      absl::StatusOr<BagSummary> one = part.reader->Summary();
      if (!one.ok()) return one.status();
      if (one->messages > 0) {
        if (summary.messages == 0 || one->start_ns < summary.start_ns) summary.start_ns = one->start_ns;
        if (summary.messages == 0 || one->end_ns > summary.end_ns) summary.end_ns = one->end_ns;
      }
      summary.messages = AddCounts(summary.messages, one->messages);
      for (const std::string& file : one->files) summary.files.push_back(file);
      for (const BagTopicSummary& row : one->topics) {
        rows[row.topic].messages = AddCounts(rows[row.topic].messages, row.messages);
      }
      compressions.insert(one->compression);
    }
    summary.compression =
        !compression_.empty() ? compression_
                              : (compressions.empty() ? "none" : absl::StrJoin(compressions, ", "));
    for (auto& [topic, row] : rows) summary.topics.push_back(std::move(row));
    return summary;
  }

 private:
  std::string format_;
  std::string compression_;
  std::vector<std::string> own_warnings_;
  std::vector<std::string> temp_dirs_;
  std::vector<Part> parts_;
  std::vector<BagConnection> connections_;
  std::map<std::string, int> global_ids_;
  mutable std::vector<std::string> all_warnings_;
};

enum class Storage { kSqlite, kMcap, kUnknown };

Storage StorageOf(const std::string& path) {
  absl::StatusOr<RandomFile> file = RandomFile::Open(path);
  if (!file.ok()) return Storage::kUnknown;
  absl::StatusOr<std::string> head = file->ReadUpTo(0, 16);
  if (!head.ok()) return Storage::kUnknown;
  if (HasPrefix(*head, std::string_view(kMcapMagic, 8))) return Storage::kMcap;
  if (HasPrefix(*head, std::string_view("SQLite format 3\0", 16))) return Storage::kSqlite;
  return Storage::kUnknown;
}

// "bag_10.db3" after "bag_9.db3": names compared with their trailing numbers as numbers.
bool NaturalLess(const std::string& a, const std::string& b) {
  auto split = [](const std::string& name) {
    const std::string stem = fs::path(name).stem().string();
    size_t digits = stem.size();
    while (digits > 0 && std::isdigit(static_cast<unsigned char>(stem[digits - 1]))) --digits;
    const std::string number = stem.substr(digits);
    return std::make_tuple(stem.substr(0, digits), number.size(), number, name);
  };
  return split(a) < split(b);
}

struct Plan {
  std::vector<std::string> files;
  std::string compression_format;
  std::string compression_mode;
  std::vector<std::string> warnings;
  bool detect_zstd = false;
};

absl::StatusOr<std::unique_ptr<BagReader>> OpenPlan(const Plan& plan) {
  if (!plan.compression_format.empty() && plan.compression_format != "zstd") {
    return absl::UnimplementedError(absl::StrCat(
        "rosbag2 compression_format \"", plan.compression_format, "\" is not read (only zstd)"));
  }
  const bool file_mode = !plan.compression_format.empty() && plan.compression_mode == "FILE";
  const bool message_mode = !plan.compression_format.empty() && plan.compression_mode == "MESSAGE";
  if (!plan.compression_format.empty() && !file_mode && !message_mode) {
    return absl::UnimplementedError(absl::StrCat("rosbag2 compression_mode \"", plan.compression_mode,
                                                 "\" is not FILE or MESSAGE"));
  }
  std::vector<std::string> temp_dirs;
  std::vector<std::pair<std::string, std::string>> opened;  // (path read, path listed)
  for (const std::string& listed : plan.files) {
    std::string path = listed;
    if (file_mode || absl::EndsWith(listed, ".zstd")) {
      std::error_code error;
      fs::path temp = fs::temp_directory_path(error);
      if (error) temp = "/tmp";
      std::string pattern = (temp / "waymark-bag-XXXXXX").string();
      if (mkdtemp(pattern.data()) == nullptr) {
        return absl::ResourceExhaustedError("cannot create a temporary folder for a compressed bag file");
      }
      temp_dirs.push_back(pattern);
      std::string name = fs::path(listed).filename().string();
      if (absl::EndsWith(name, ".zstd")) name.resize(name.size() - 5);
      path = (fs::path(pattern) / name).string();
      if (absl::Status status = DecompressZstdFile(listed, path); !status.ok()) {
        for (const std::string& dir : temp_dirs) {
          std::error_code error;
          fs::remove_all(dir, error);
        }
        return status;
      }
    }
    opened.emplace_back(path, listed);
  }
  std::set<Storage> storages;
  std::vector<std::pair<std::unique_ptr<BagReader>, std::string>> readers;
  absl::Status failure;
  for (const auto& [path, listed] : opened) {
    const Storage storage = StorageOf(path);
    absl::StatusOr<std::unique_ptr<BagReader>> reader;
    if (storage == Storage::kSqlite) {
      reader = OpenDb3File(path, Db3Options{message_mode, plan.detect_zstd});
    } else if (storage == Storage::kMcap) {
      absl::StatusOr<RandomFile> file = RandomFile::Open(path);
      reader = file.ok() ? OpenMcapFile(*std::move(file), "rosbag2 mcap") : file.status();
    } else if (std::error_code error; !fs::exists(path, error)) {
      // The non-throwing overloads throughout: a listed name may be anything (one too long for
      // the file system threw std::filesystem_error out of the reader, found by fuzzing).
      reader = absl::NotFoundError(absl::StrCat(
          listed, ": listed by the bag's metadata but ",
          error ? absl::StrCat("unreadable (", error.message(), ")") : std::string("missing")));
    } else {
      reader = absl::InvalidArgumentError(
          absl::StrCat(listed, ": neither an sqlite3 (.db3) nor an MCAP storage file"));
    }
    if (!reader.ok()) {
      failure = reader.status();
      break;
    }
    storages.insert(storage);
    readers.emplace_back(*std::move(reader), listed);
  }
  if (!failure.ok()) {
    readers.clear();
    for (const std::string& dir : temp_dirs) {
      std::error_code error;
      fs::remove_all(dir, error);
    }
    return failure;
  }
  std::string format = storages.size() == 1 && *storages.begin() == Storage::kMcap ? "rosbag2 mcap"
                       : storages.size() == 1                                      ? "rosbag2 sqlite3"
                                                                                   : "rosbag2 sqlite3 + mcap";
  std::string compression;
  if (file_mode) compression = "zstd (per file)";
  if (message_mode) compression = "zstd (per message)";
  auto bag = std::make_unique<MergedBag>(std::move(format), std::move(compression), plan.warnings,
                                         std::move(temp_dirs));
  for (auto& [reader, listed] : readers) bag->AddPart(std::move(reader), listed);
  return std::unique_ptr<BagReader>(std::move(bag));
}

absl::StatusOr<Plan> PlanFromMetadata(const std::string& yaml) {
  absl::StatusOr<Rosbag2Metadata> metadata = ReadRosbag2Metadata(yaml);
  if (!metadata.ok()) return metadata.status();
  Plan plan;
  plan.files = metadata->files;
  plan.compression_format = metadata->compression_format;
  plan.compression_mode = metadata->compression_mode;
  return plan;
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenRosbag2(const std::string& path) {
  std::error_code error;
  if (!fs::is_directory(path, error)) {
    absl::StatusOr<Plan> plan = PlanFromMetadata(path);
    if (!plan.ok()) return plan.status();
    return OpenPlan(*plan);
  }
  const fs::path metadata = fs::path(path) / "metadata.yaml";
  if (fs::exists(metadata, error)) {
    absl::StatusOr<Plan> plan = PlanFromMetadata(metadata.string());
    if (!plan.ok()) return plan.status();
    return OpenPlan(*plan);
  }
  Plan plan;
  for (fs::directory_iterator it(path, error); !error && it != fs::directory_iterator();
       it.increment(error)) {
    const std::string name = it->path().string();
    std::error_code type_error;
    if (it->is_regular_file(type_error) &&
        (absl::EndsWith(name, ".db3") || absl::EndsWith(name, ".mcap"))) {
      plan.files.push_back(name);
    }
  }
  if (error) return absl::NotFoundError(absl::StrCat(path, ": cannot list the folder: ", error.message()));
  if (plan.files.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": not a bag folder (no metadata.yaml and no .db3 or .mcap storage files)"));
  }
  std::sort(plan.files.begin(), plan.files.end(), NaturalLess);
  if (plan.files.size() > 1) {
    plan.warnings.push_back(absl::StrCat("no metadata.yaml: the folder's ", plan.files.size(),
                                         " storage files are read as one split bag, in name order"));
  }
  plan.detect_zstd = true;
  return OpenPlan(plan);
}

absl::StatusOr<std::unique_ptr<BagReader>> OpenRosbag2File(const std::string& path, bool mcap) {
  // The folder's metadata says how the file is compressed, when it lists it.
  const fs::path yaml = fs::path(path).parent_path() / "metadata.yaml";
  std::error_code error;
  Plan plan;
  plan.files = {path};
  plan.detect_zstd = true;
  if (fs::exists(yaml, error)) {
    absl::StatusOr<Rosbag2Metadata> metadata = ReadRosbag2Metadata(yaml.string());
    if (metadata.ok()) {
      for (const std::string& listed : metadata->files) {
        if (fs::equivalent(listed, path, error)) {
          plan.compression_format = metadata->compression_format;
          plan.compression_mode = metadata->compression_mode;
          plan.detect_zstd = false;
          if (metadata->files.size() > 1) {
            plan.warnings.push_back(absl::StrCat(
                "this is one of the ", metadata->files.size(),
                " files of a split bag; open its folder to read them all"));
          }
        }
      }
    }
  }
  if (mcap && plan.compression_mode != "FILE") {
    absl::StatusOr<RandomFile> file = RandomFile::Open(path);
    if (!file.ok()) return file.status();
    return OpenMcapFile(*std::move(file), "MCAP");
  }
  return OpenPlan(plan);
}

}  // namespace waymark::bags
