// Bags written by tools we did not write, read back byte for byte: ROS 1 bags by ROS's own writer
// (Debian's python3-rosbag; chunks none, bz2 and lz4), MCAP files and a split rosbag2-on-MCAP
// folder by Foxglove's @mcap/core with @foxglove/cdr (tests/js), rosbag2 sqlite3 bags in both
// schemas by Python's sqlite3 on rosbag2's own table definitions. Each writer also writes what
// it was given (topic, type, log time, bytes), in log-time order: the reader must give exactly that.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "client/bags/bag_reader.h"
#include "tests/bags/bag_test_util.h"

namespace waymark::bags {
namespace {

const std::string kSource = WAYMARK_SOURCE_DIR;

int RunCommand(const std::string& command) {
  const int code = std::system(command.c_str());
  return WIFEXITED(code) ? WEXITSTATUS(code) : -1;
}

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
}

std::string Hex(const std::string& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (unsigned char c : bytes) {
    out += digits[c >> 4];
    out += digits[c & 15];
  }
  return out;
}

int64_t Number(const nlohmann::json& value) {
  return value.is_string() ? std::stoll(value.get<std::string>()) : value.get<int64_t>();
}

// The bag at `path` gives back exactly `expected`, in order.
void ExpectSameMessages(const std::string& path, const nlohmann::json& expected,
                        const std::string& format) {
  SCOPED_TRACE(path);
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(path);
  ASSERT_TRUE(bag.ok()) << bag.status();
  absl::StatusOr<BagSummary> summary = (*bag)->Summary();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->format, format);
  EXPECT_EQ(summary->messages, static_cast<int64_t>(expected.size()));
  const std::vector<ReadMessage> messages = ReadAll(**bag);
  ASSERT_EQ(messages.size(), expected.size());
  for (size_t i = 0; i < messages.size(); ++i) {
    const nlohmann::json& want = expected[i];
    ASSERT_EQ(messages[i].topic, want["topic"].get<std::string>()) << "message " << i;
    // Types as ROS 1 names: "std_msgs/msg/String" is read as "std_msgs/String".
    std::string type = want["type"].get<std::string>();
    if (size_t at = type.find("/msg/"); at != std::string::npos) type.erase(at, 4);
    ASSERT_EQ(messages[i].type, type) << "message " << i;
    ASSERT_EQ(messages[i].time_ns, Number(want["time_ns"])) << "message " << i;
    ASSERT_EQ(Hex(messages[i].data), want["data"].get<std::string>()) << "message " << i;
  }
  EXPECT_TRUE((*bag)->warnings().empty()) << (*bag)->warnings().front();
}

TEST(WrittenBags, RosOneBagsFromRosbagReadBackByteForByte) {
  TempDir dir;
  ASSERT_FALSE(dir.path().empty());
  ASSERT_EQ(RunCommand("/usr/bin/python3 " + kSource + "/tests/bags/write_ros1_bag.py " + dir.path()), 0)
      << "write_ros1_bag.py failed: is Debian's python3-rosbag installed (scripts/install-deps.sh)?";
  const nlohmann::json expected = ReadJson(dir.path() + "/ros1.json");
  ASSERT_TRUE(expected.is_array() && expected.size() > 100);
  for (const char* name : {"none", "bz2", "lz4"}) {
    ExpectSameMessages(dir.path() + "/" + name + ".bag", expected, "ROS 1 bag v2.0");
  }
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(dir.path() + "/lz4.bag");
  ASSERT_TRUE(bag.ok());
  EXPECT_EQ((*bag)->Summary()->compression, "lz4");
}

TEST(WrittenBags, McapAndRosbagTwoOnMcapFromFoxgloveWritersReadBackByteForByte) {
  TempDir dir;
  ASSERT_FALSE(dir.path().empty());
  ASSERT_EQ(RunCommand("NODE_PATH=" + std::string(WAYMARK_NODE_MODULES) + " node " + kSource +
                "/tests/bags/write_mcap.js " + dir.path()),
            0)
      << "write_mcap.js failed: are tests/js's node packages installed (scripts/install-deps.sh)?";
  const nlohmann::json expected = ReadJson(dir.path() + "/mcap.json");
  ASSERT_TRUE(expected.is_object());
  ExpectSameMessages(dir.path() + "/ros2.mcap", expected["ros2.mcap"], "MCAP (profile ros2)");
  ExpectSameMessages(dir.path() + "/nosummary.mcap", expected["nosummary.mcap"], "MCAP (profile ros2)");
  ExpectSameMessages(dir.path() + "/ros1.mcap", expected["ros1.mcap"], "MCAP (profile ros1)");
  ExpectSameMessages(dir.path() + "/rosbag2", expected["rosbag2"], "rosbag2 mcap");

  absl::StatusOr<std::unique_ptr<BagReader>> ros1 = OpenBag(dir.path() + "/ros1.mcap");
  ASSERT_TRUE(ros1.ok());
  ASSERT_EQ((*ros1)->connections().size(), 1u);
  EXPECT_EQ((*ros1)->connections()[0].encoding, MessageEncoding::kRos1);
  EXPECT_EQ((*ros1)->connections()[0].md5sum, "992ce8a1687cec8c8bd883ec73ca41d1");
  EXPECT_EQ((*ros1)->connections()[0].callerid, "/talker");
}

TEST(WrittenBags, RosbagTwoSqliteInBothSchemasReadsBackByteForByte) {
  TempDir dir;
  ASSERT_FALSE(dir.path().empty());
  ASSERT_EQ(RunCommand("/usr/bin/python3 " + kSource + "/tests/bags/write_rosbag2_db3.py " + dir.path()), 0);
  const nlohmann::json expected = ReadJson(dir.path() + "/db3.json");
  ASSERT_TRUE(expected.is_object());
  ExpectSameMessages(dir.path() + "/db3_old", expected["db3_old"], "rosbag2 sqlite3");
  ExpectSameMessages(dir.path() + "/db3_new", expected["db3_new"], "rosbag2 sqlite3");

  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(dir.path() + "/db3_new");
  ASSERT_TRUE(bag.ok());
  for (const BagConnection& connection : (*bag)->connections()) {
    EXPECT_EQ(connection.encoding, MessageEncoding::kCdr);
    EXPECT_FALSE(connection.definition.empty()) << connection.topic << ": from message_definitions";
  }
}

}  // namespace
}  // namespace waymark::bags
