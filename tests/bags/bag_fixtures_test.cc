// Every bag in ../shared/data/bags, opened and read: topics, types and counts as its SOURCES.md
// lists them (counts SOURCES.md leaves out, e.g. the turtlesim color sensors, are checked for
// agreement between the index and the messages read, and between the three compressions).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>

#include "client/bags/bag_reader.h"
#include "tests/bags/bag_test_util.h"

namespace waymark::bags {
namespace {

std::filesystem::path BagsDir() { return std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "bags"; }

struct Fixture {
  std::string path;  // under ../shared/data/bags
  std::string format;
  std::map<std::string, int64_t> counts;       // topic -> messages (SOURCES.md)
  std::map<std::string, std::string> types;    // topic -> type, where SOURCES.md names it
  std::string compression;                      // "" = not checked
};

void PrintTo(const Fixture& fixture, std::ostream* out) { *out << fixture.path; }

const std::map<std::string, int64_t> kTurtlesim = {
    {"/tf", 2688}, {"/tf_static", 1}, {"/turtle1/pose", 1344}, {"/turtle2/pose", 1344},
    {"/turtle1/cmd_vel", 357}, {"/turtle2/cmd_vel", 208}, {"/rosout", 10}};
const std::map<std::string, std::string> kTurtlesimTypes = {{"/tf", "tf/tfMessage"},
                                                            {"/tf_static", "tf2_msgs/TFMessage"},
                                                            {"/turtle1/pose", "turtlesim/Pose"},
                                                            {"/turtle1/cmd_vel", "geometry_msgs/Twist"}};
const std::string kR2 = "rosbag2_fixtures/";

std::vector<Fixture> Fixtures() {
  return {
      {"zaki_urg_feb13_subset/subset.bag", "ROS 1 bag v2.0",
       {{"/scan", 186}, {"/odom", 233}, {"/tf", 796}, {"/cmd_vel", 158}},
       {{"/scan", "sensor_msgs/LaserScan"}, {"/odom", "nav_msgs/Odometry"},
        {"/tf", "tf2_msgs/TFMessage"}, {"/cmd_vel", "geometry_msgs/Twist"}}, "none"},
      {"embag_stage_sim/test_stage_lz4.bag", "ROS 1 bag v2.0",
       {{"/base_scan", 1727}, {"/base_pose_ground_truth", 1727}},
       {{"/base_scan", "sensor_msgs/LaserScan"}, {"/base_pose_ground_truth", "nav_msgs/Odometry"}}, "lz4"},
      {"ccny_scan_tools_demo/demo.bag", "ROS 1 bag v2.0", {{"/scan", 360}},
       {{"/scan", "sensor_msgs/LaserScan"}}, "none"},
      {"fiducials_aruco_camera/aruco_marker.bag", "ROS 1 bag v2.0",
       {{"/raspicam_node/image/compressed", 1}, {"/raspicam_node/camera_info", 1}},
       {{"/raspicam_node/image/compressed", "sensor_msgs/CompressedImage"},
        {"/raspicam_node/camera_info", "sensor_msgs/CameraInfo"}}, ""},
      {"fiducials_aruco_camera/aruco_images.bag", "ROS 1 bag v2.0",
       {{"/raspicam_node/image/compressed", 1}, {"/raspicam_node/camera_info", 15}}, {}, ""},
      {"rosnumpy_test_fixture/test.bag", "ROS 1 bag v2.0",
       {{"/image", 1}, {"/compressedimage", 1}, {"/pointcloud", 1}, {"/occupancygrid", 1},
        {"/pose", 1}, {"/point", 1}, {"/quaternion", 1}, {"/transform", 1}, {"/vector3", 1}},
       {{"/image", "sensor_msgs/Image"}, {"/compressedimage", "sensor_msgs/CompressedImage"},
        {"/occupancygrid", "nav_msgs/OccupancyGrid"}}, ""},
      {"rosbagjs_fixtures/example.bag", "ROS 1 bag v2.0", kTurtlesim, kTurtlesimTypes, "none"},
      {"rosbagjs_fixtures/example-bz2.bag", "ROS 1 bag v2.0", kTurtlesim, kTurtlesimTypes, "bz2"},
      {"rosbagjs_fixtures/example-lz4.bag", "ROS 1 bag v2.0", kTurtlesim, kTurtlesimTypes, "lz4"},
      {"rosbagjs_fixtures/example-unsorted-chunks.bag", "ROS 1 bag v2.0", {{"foo", 3}},
       {{"foo", "std_msgs/String"}}, ""},
      {"rosbagjs_fixtures/no-messages.bag", "ROS 1 bag v2.0", {}, {}, ""},
      {kR2 + "rosbag2_py/test/resources/sqlite3/talker", "rosbag2 sqlite3",
       {{"/topic", 10}, {"/rosout", 10}, {"/parameter_events", 0}},
       {{"/topic", "std_msgs/String"}}, "none"},
      {kR2 + "rosbag2_py/test/resources/sqlite3/talker/talker.db3", "rosbag2 sqlite3",
       {{"/topic", 10}, {"/rosout", 10}, {"/parameter_events", 0}}, {}, ""},
      {kR2 + "rosbag2_py/test/resources/mcap/talker", "rosbag2 mcap",
       {{"/topic", 10}, {"/rosout", 10}, {"/parameter_events", 0}},
       {{"/topic", "std_msgs/String"}}, "zstd"},
      {kR2 + "rosbag2_py/test/resources/mcap/talker/talker.mcap", "MCAP (profile ros2)",
       {{"/topic", 10}, {"/rosout", 10}, {"/parameter_events", 0}}, {}, "zstd"},
      {kR2 + "rosbag2_tests/resources/sqlite3/cdr_test", "rosbag2 sqlite3",
       {{"/test_topic", 3}, {"/array_topic", 4}},
       {{"/test_topic", "test_msgs/BasicTypes"}, {"/array_topic", "test_msgs/Arrays"}}, ""},
      {kR2 + "rosbag2_tests/resources/mcap/cdr_test/cdr_test_0.mcap", "MCAP (profile ros2)",
       {{"/test_topic", 3}, {"/array_topic", 4}}, {}, "none"},
      {kR2 + "rosbag2_py/test/resources/mcap/reindex_test_bags/multiple_files", "rosbag2 mcap",
       {{"/chatter", 1324 + 1324 + 529}}, {{"/chatter", "std_msgs/String"}}, ""},
      {kR2 + "rosbag2_py/test/resources/mcap/reindex_test_bags/multiple_files/multiple_files_2.mcap",
       "MCAP (profile ros2)", {{"/chatter", 529}}, {}, ""},
      {kR2 + "rosbag2_tests/resources/sqlite3/bag_with_topics_and_service_events", "rosbag2 sqlite3",
       {{"/test_service1/_service_event", 4}, {"/test_service2/_service_event", 4}},
       {{"/test_topic1", "test_msgs/Strings"}}, ""},
      {kR2 + "rosbag2_tests/resources/mcap/bag_with_topics_and_service_events", "rosbag2 mcap",
       {{"/test_service1/_service_event", 4}, {"/test_service2/_service_event", 4}},
       {{"/test_topic1", "test_msgs/Strings"}}, ""},
      {kR2 + "rosbag2_cpp/test/rosbag2_cpp/bags/only_topics.mcap", "MCAP (profile ros2)",
       {{"/parameter_events", 7}}, {}, ""},
      {kR2 + "rosbag2_cpp/test/rosbag2_cpp/bags/topics_and_services.db3", "rosbag2 sqlite3",
       {{"/parameter_events", 7}}, {}, ""},
      {kR2 + "rosbag2_transport/test/resources/sqlite3/test_bag_for_seek", "rosbag2 sqlite3",
       {{"topic1", 5}}, {{"topic1", "test_msgs/BasicTypes"}}, ""},
      {kR2 + "rosbag2_transport/test/resources/mcap/test_bag_for_seek", "rosbag2 mcap",
       {{"topic1", 5}}, {{"topic1", "test_msgs/BasicTypes"}}, ""},
      {kR2 + "ros2bag/test/resources/empty_bag", "rosbag2 sqlite3",
       {{"/rosout", 0}, {"/parameter_events", 0}}, {}, ""},
      {kR2 + "ros2bag/test/resources/reindex_test_bags/message_compression/"
             "message_compression_target.yaml",
       "rosbag2 sqlite3", {{"/topic", 120 + 120 + 120 + 9}, {"/rosout", 260 + 240 + 240 + 18}},
       {{"/topic", "std_msgs/String"}}, "zstd (per message)"},
  };
}

class BagFixtureTest : public testing::TestWithParam<Fixture> {};

TEST_P(BagFixtureTest, TopicsTypesAndCountsAreTheListedOnes) {
  const Fixture& fixture = GetParam();
  const std::filesystem::path path = BagsDir() / fixture.path;
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(path.string());
  ASSERT_TRUE(bag.ok()) << bag.status();
  absl::StatusOr<BagSummary> summary = (*bag)->Summary();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->format, fixture.format);
  if (!fixture.compression.empty()) EXPECT_EQ(summary->compression, fixture.compression);

  const std::vector<ReadMessage> messages = ReadAll(**bag);
  const std::map<std::string, int64_t> read = CountByTopic(messages);
  std::map<std::string, int64_t> listed;
  std::map<std::string, std::string> types;
  for (const BagTopicSummary& topic : summary->topics) {
    listed[topic.topic] = topic.messages;
    types[topic.topic] = topic.type;
  }
  for (const auto& [topic, count] : fixture.counts) {
    EXPECT_EQ(listed.count(topic) ? listed[topic] : -1, count) << topic << " in the summary";
    EXPECT_EQ(read.count(topic) ? read.at(topic) : 0, count) << topic << " read";
  }
  for (const auto& [topic, type] : fixture.types) EXPECT_EQ(types[topic], type) << topic;
  // What the summary counts is what is read, topic by topic.
  for (const auto& [topic, count] : listed) {
    EXPECT_EQ(read.count(topic) ? read.at(topic) : 0, count) << topic;
  }
  EXPECT_EQ(summary->messages, static_cast<int64_t>(messages.size()));
  for (size_t i = 1; i < messages.size(); ++i) {
    ASSERT_LE(messages[i - 1].time_ns, messages[i].time_ns) << "message " << i << " out of order";
  }
  if (!messages.empty()) {
    EXPECT_EQ(summary->start_ns, messages.front().time_ns);
    EXPECT_EQ(summary->end_ns, messages.back().time_ns);
  }
  // Whole and intact: nothing to warn about (the split folder without metadata.yaml says so).
  for (const std::string& warning : (*bag)->warnings()) {
    EXPECT_NE(warning.find("metadata.yaml"), std::string::npos) << warning;
  }
}

INSTANTIATE_TEST_SUITE_P(SharedBags, BagFixtureTest, testing::ValuesIn(Fixtures()),
                         [](const testing::TestParamInfo<Fixture>& info) {
                           std::string name;
                           for (char c : info.param.path.substr(info.param.path.rfind('/', info.param.path.size() - 2) + 1)) {
                             name += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
                           }
                           return name + "_" + std::to_string(info.index);
                         });

TEST(BagFixtures, TheThreeCompressionsOfTheTurtlesimBagHoldTheSameBytes) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  std::vector<std::vector<ReadMessage>> all;
  for (const char* name : {"example.bag", "example-bz2.bag", "example-lz4.bag"}) {
    absl::StatusOr<std::unique_ptr<BagReader>> bag =
        OpenBag((BagsDir() / "rosbagjs_fixtures" / name).string());
    ASSERT_TRUE(bag.ok()) << bag.status();
    all.push_back(ReadAll(**bag));
  }
  ASSERT_EQ(all[0].size(), 8647u);  // SOURCES.md's topics plus the two color sensors
  for (size_t k = 1; k < all.size(); ++k) {
    ASSERT_EQ(all[k].size(), all[0].size());
    for (size_t i = 0; i < all[0].size(); ++i) {
      ASSERT_EQ(all[k][i].topic, all[0][i].topic) << i;
      ASSERT_EQ(all[k][i].time_ns, all[0][i].time_ns) << i;
      ASSERT_EQ(all[k][i].data, all[0][i].data) << i;
    }
  }
}

TEST(BagFixtures, UnsortedChunksComeOutInTimeOrder) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> bag =
      OpenBag((BagsDir() / "rosbagjs_fixtures/example-unsorted-chunks.bag").string());
  ASSERT_TRUE(bag.ok()) << bag.status();
  const std::vector<ReadMessage> messages = ReadAll(**bag);
  ASSERT_EQ(messages.size(), 3u);
  // The chunks hold t = 2, 3, 1 s in file order (SOURCES.md).
  EXPECT_EQ(messages[0].time_ns, 1000000000);
  EXPECT_EQ(messages[1].time_ns, 2000000000);
  EXPECT_EQ(messages[2].time_ns, 3000000000);
}

TEST(BagFixtures, SelectReadsOnlyTheChosenConnections) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  for (const char* relative : {"zaki_urg_feb13_subset/subset.bag",
                               "rosbag2_fixtures/rosbag2_py/test/resources/sqlite3/talker",
                               "rosbag2_fixtures/rosbag2_py/test/resources/mcap/talker/talker.mcap"}) {
    absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag((BagsDir() / relative).string());
    ASSERT_TRUE(bag.ok()) << bag.status();
    std::vector<int> wanted;
    std::string topic;
    for (const BagConnection& connection : (*bag)->connections()) {
      if (connection.topic == "/scan" || connection.topic == "/topic") {
        wanted.push_back(connection.id);
        topic = connection.topic;
      }
    }
    ASSERT_FALSE(wanted.empty()) << relative;
    (*bag)->Select(wanted);
    const std::map<std::string, int64_t> counts = CountByTopic(ReadAll(**bag));
    ASSERT_EQ(counts.size(), 1u) << relative;
    EXPECT_EQ(counts.begin()->first, topic);
    EXPECT_EQ(counts.begin()->second, topic == "/scan" ? 186 : 10) << relative;
  }
}

TEST(BagFixtures, RosbagTwoTypesAreNormalizedAndKeepTheirRawName) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(
      (BagsDir() / "rosbag2_fixtures/rosbag2_py/test/resources/mcap/talker/talker.mcap").string());
  ASSERT_TRUE(bag.ok()) << bag.status();
  bool found = false;
  for (const BagConnection& connection : (*bag)->connections()) {
    if (connection.topic != "/topic") continue;
    found = true;
    EXPECT_EQ(connection.type, "std_msgs/String");
    EXPECT_EQ(connection.raw_type, "std_msgs/msg/String");
    EXPECT_EQ(connection.encoding, MessageEncoding::kCdr);
    EXPECT_EQ(connection.encoding_name, "cdr");
    EXPECT_NE(connection.definition.find("string data"), std::string::npos) << connection.definition;
  }
  EXPECT_TRUE(found);
}

TEST(BagFixtures, RosOneConnectionsCarryTheirHeader) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> bag =
      OpenBag((BagsDir() / "ccny_scan_tools_demo/demo.bag").string());
  ASSERT_TRUE(bag.ok()) << bag.status();
  ASSERT_EQ((*bag)->connections().size(), 1u);
  const BagConnection& scan = (*bag)->connections()[0];
  EXPECT_EQ(scan.encoding, MessageEncoding::kRos1);
  EXPECT_EQ(scan.callerid, "/hokuyo_node");  // SOURCES.md
  EXPECT_EQ(scan.md5sum.size(), 32u);
  EXPECT_NE(scan.definition.find("float32[] ranges"), std::string::npos);
}

TEST(BagFixtures, OldRosrecordFormatIsRefusedNamingTheVersionAndTheWayOut) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> bag =
      OpenBag((BagsDir() / "ccny_scan_tools_demo/demo_rosrecord_v1.2.bag").string());
  ASSERT_FALSE(bag.ok());
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(bag.status().message().find("#ROSRECORD V1.2"), std::string::npos) << bag.status();
  EXPECT_NE(bag.status().message().find("rosbag fix"), std::string::npos) << bag.status();
}

TEST(BagFixtures, EmptyFileIsNotABag) {
  if (!std::filesystem::exists(BagsDir())) GTEST_SKIP() << BagsDir() << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> bag =
      OpenBag((BagsDir() / "rosbagjs_fixtures/empty-file.bag").string());
  ASSERT_FALSE(bag.ok());
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bag.status().message().find("empty file (0 bytes)"), std::string::npos) << bag.status();
}

}  // namespace
}  // namespace waymark::bags
