#include "tests/bags/bag_test_util.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <map>

namespace waymark::bags {

std::vector<ReadMessage> ReadAll(BagReader& reader) {
  std::map<int, const BagConnection*> connections;
  for (const BagConnection& connection : reader.connections()) connections[connection.id] = &connection;
  std::vector<ReadMessage> out;
  BagMessage message;
  while (true) {
    absl::StatusOr<bool> more = reader.Next(&message);
    EXPECT_TRUE(more.ok()) << more.status();
    if (!more.ok() || !*more) break;
    ReadMessage read;
    auto it = connections.find(message.connection_id);
    EXPECT_NE(it, connections.end()) << "message on undeclared connection " << message.connection_id;
    if (it != connections.end()) {
      read.topic = it->second->topic;
      read.type = it->second->type;
    }
    read.time_ns = message.log_time_ns;
    read.data = message.data;
    out.push_back(std::move(read));
  }
  return out;
}

std::map<std::string, int64_t> CountByTopic(const std::vector<ReadMessage>& messages) {
  std::map<std::string, int64_t> counts;
  for (const ReadMessage& message : messages) ++counts[message.topic];
  return counts;
}

TempDir::TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "waymark-bags-test-XXXXXX").string();
  if (mkdtemp(pattern.data()) != nullptr) path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code error;
  if (!path_.empty()) std::filesystem::remove_all(path_, error);
}

}  // namespace waymark::bags
