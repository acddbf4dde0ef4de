#ifndef WAYMARK_TESTS_BAGS_BAG_TEST_UTIL_H_
#define WAYMARK_TESTS_BAGS_BAG_TEST_UTIL_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "client/bags/bag_reader.h"

namespace waymark::bags {

struct ReadMessage {
  std::string topic;
  std::string type;
  int64_t time_ns = 0;
  std::string data;
};

// Every message of the bag, in the order Next gives them; fails the test on an error.
std::vector<ReadMessage> ReadAll(BagReader& reader);

// Messages per topic.
std::map<std::string, int64_t> CountByTopic(const std::vector<ReadMessage>& messages);

// A temporary folder, removed with the object.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace waymark::bags

#endif  // WAYMARK_TESTS_BAGS_BAG_TEST_UTIL_H_
