// waymark-bag-read-bench [--runs N] [--carmen LOG]... BAG...: how fast the bag readers hand out
// messages. Each run opens the bag and reads every message (the serialized bytes, not decoded);
// the median of N runs (5 by default) is printed as file MB/s (the bytes on disk, all files of a
// split bag) and messages/s. --carmen reads a CARMEN log's records the same way, for comparison
// with the path replays took before bags.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "client/bags/bag_reader.h"
#include "client/datasets/carmen_log.h"

namespace {

namespace fs = std::filesystem;

int64_t BytesOnDisk(const std::string& path) {
  std::error_code error;
  if (fs::path(path).extension() == ".yaml") return BytesOnDisk(fs::path(path).parent_path().string());
  if (!fs::is_directory(path, error)) return static_cast<int64_t>(fs::file_size(path, error));
  int64_t total = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(path, error)) {
    if (entry.is_regular_file()) total += static_cast<int64_t>(entry.file_size());
  }
  return total;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// Seconds for one full read, and the messages read; negative on an error.
double ReadBag(const std::string& path, int64_t* messages, int64_t* payload) {
  const auto start = std::chrono::steady_clock::now();
  auto bag = waymark::bags::OpenBag(path);
  if (!bag.ok()) {
    std::fprintf(stderr, "%s\n", std::string(bag.status().message()).c_str());
    return -1;
  }
  waymark::bags::BagMessage message;
  *messages = 0;
  *payload = 0;
  while (true) {
    auto more = (*bag)->Next(&message);
    if (!more.ok()) return -1;
    if (!*more) break;
    ++*messages;
    *payload += static_cast<int64_t>(message.data.size());
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double ReadCarmen(const std::string& path, int64_t* records, int64_t* payload) {
  const auto start = std::chrono::steady_clock::now();
  auto log = waymark::adapters::CarmenLogReader::Open(path);
  if (!log.ok()) return -1;
  waymark::adapters::CarmenRecord record;
  *records = 0;
  *payload = 0;
  while (true) {
    auto more = (*log)->Next(&record);
    if (!more.ok()) return -1;
    if (!*more) break;
    ++*records;
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 5;
  std::vector<std::pair<std::string, bool>> inputs;  // (path, is CARMEN)
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (arg == "--carmen" && i + 1 < argc) {
      inputs.emplace_back(argv[++i], true);
    } else {
      inputs.emplace_back(arg, false);
    }
  }
  if (inputs.empty()) {
    std::fprintf(stderr, "usage: waymark-bag-read-bench [--runs N] [--carmen LOG]... BAG...\n");
    return 2;
  }
  std::printf("%-60s %10s %10s %10s %12s\n", "input", "MB", "messages", "MB/s", "messages/s");
  for (const auto& [path, carmen] : inputs) {
    std::vector<double> seconds;
    int64_t messages = 0, payload = 0;
    for (int run = 0; run < runs; ++run) {
      const double s = carmen ? ReadCarmen(path, &messages, &payload) : ReadBag(path, &messages, &payload);
      if (s < 0) {
        std::fprintf(stderr, "%s: read failed\n", path.c_str());
        return 1;
      }
      seconds.push_back(s);
    }
    const double median = Median(seconds);
    const double megabytes = static_cast<double>(BytesOnDisk(path)) / 1e6;
    std::string name = fs::path(path).filename().string();
    if (carmen) name = "CARMEN " + name;
    std::printf("%-60s %10.2f %10lld %10.1f %12.0f\n", name.c_str(), megabytes,
                static_cast<long long>(messages), megabytes / median, messages / median);
  }
  return 0;
}
