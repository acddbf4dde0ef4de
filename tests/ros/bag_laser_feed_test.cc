// BagLaserFeed over an in-memory BagReader: scans in header-stamp order within the lookahead
// (record order does not matter), what it skips and why, odometry interpolated at each scan's
// stamp from an Odometry topic or from the TF chain, the mounting from /tf_static, topic choice.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "client/ros/bag_laser_feed.h"

namespace waymark::ros {
namespace {

using ::testing::HasSubstr;

// ROS 1 serialization, written here for the reader's input (the decoders themselves are tested
// on genpy's and Foxglove's bytes in ros_messages_test.cc).
class Ros1Writer {
 public:
  template <typename T>
  Ros1Writer& Put(T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    data_.append(bytes, sizeof(T));
    return *this;
  }
  Ros1Writer& Str(const std::string& s) {
    Put<uint32_t>(static_cast<uint32_t>(s.size()));
    data_ += s;
    return *this;
  }
  Ros1Writer& Header(int64_t stamp_ns, const std::string& frame) {
    Put<uint32_t>(0).Put<uint32_t>(static_cast<uint32_t>(stamp_ns / 1000000000));
    Put<uint32_t>(static_cast<uint32_t>(stamp_ns % 1000000000));
    return Str(frame);
  }
  Ros1Writer& Pose(double x, double y, double yaw) {
    Put(x).Put(y).Put(0.0);
    return Put(0.0).Put(0.0).Put(std::sin(yaw / 2)).Put(std::cos(yaw / 2));
  }
  std::string data() const { return data_; }

 private:
  std::string data_;
};

std::string Scan(int64_t stamp_ns, const std::string& frame, std::vector<float> ranges) {
  Ros1Writer w;
  w.Header(stamp_ns, frame);
  w.Put(-1.0f).Put(1.0f).Put(0.5f).Put(0.0f).Put(0.1f).Put(0.1f).Put(4.0f);
  w.Put<uint32_t>(static_cast<uint32_t>(ranges.size()));
  for (float r : ranges) w.Put(r);
  return w.Put<uint32_t>(0).data();
}

std::string Odometry(int64_t stamp_ns, double x, double y, double yaw) {
  Ros1Writer w;
  w.Header(stamp_ns, "odom").Str("base_link").Pose(x, y, yaw);
  for (int i = 0; i < 36 + 6 + 36; ++i) w.Put(0.0);
  return w.data();
}

struct Edge {
  std::string parent, child;
  double x, y, yaw;
};
std::string Tf(int64_t stamp_ns, const std::vector<Edge>& edges) {
  Ros1Writer w;
  w.Put<uint32_t>(static_cast<uint32_t>(edges.size()));
  for (const Edge& e : edges) w.Header(stamp_ns, e.parent).Str(e.child).Pose(e.x, e.y, e.yaw);
  return w.data();
}

class FakeBag : public bags::BagReader {
 public:
  void AddConnection(int id, const std::string& topic, const std::string& type) {
    bags::BagConnection c;
    c.id = id;
    c.topic = topic;
    c.type = type;
    c.encoding = bags::MessageEncoding::kRos1;
    c.encoding_name = "ros1";
    connections_.push_back(c);
  }
  void Add(int connection, std::string data) {
    messages_.push_back({connection, static_cast<int64_t>(messages_.size()), std::move(data)});
  }
  const std::vector<bags::BagConnection>& connections() const override { return connections_; }
  absl::StatusOr<bags::BagSummary> Summary() override { return bags::BagSummary{}; }
  absl::StatusOr<bool> Next(bags::BagMessage* message) override {
    while (next_ < messages_.size()) {
      const bags::BagMessage& m = messages_[next_++];
      if (wanted_.empty() || std::count(wanted_.begin(), wanted_.end(), m.connection_id)) {
        *message = m;
        return true;
      }
    }
    return false;
  }
  void Select(const std::vector<int>& wanted) override { wanted_ = wanted; }
  const std::vector<std::string>& warnings() const override { return warnings_; }

 private:
  std::vector<bags::BagConnection> connections_;
  std::vector<bags::BagMessage> messages_;
  std::vector<int> wanted_;
  std::vector<std::string> warnings_;
  size_t next_ = 0;
};

constexpr int64_t kS = 1000000000;

std::vector<adapters::LaserSample> ReadAll(BagLaserFeed& feed) {
  std::vector<adapters::LaserSample> samples;
  adapters::LaserSample sample;
  while (true) {
    auto more = feed.Next(&sample);
    EXPECT_TRUE(more.ok()) << more.status();
    if (!more.ok() || !*more) break;
    samples.push_back(sample);
  }
  return samples;
}

TEST(BagLaserFeedTest, HeaderStampOrderInterpolatedOdometryAndWhatIsSkipped) {
  auto bag = std::make_unique<FakeBag>();
  bag->AddConnection(1, "/scan", "sensor_msgs/LaserScan");
  bag->AddConnection(2, "/odom", "nav_msgs/Odometry");
  bag->AddConnection(3, "/cmd_vel", "geometry_msgs/Twist");
  bag->Add(3, "not decoded: not selected");
  bag->Add(1, Scan(9 * kS, "/base_link", {1, 2, 3, 4, 5}));  // before any odometry: skipped
  bag->Add(2, Odometry(10 * kS, 0, 0, 0));
  bag->Add(1, Scan(12 * kS, "base_link", {1, 5, 3, 0.05f, 2}));  // recorded before the 11 s one
  bag->Add(1, Scan(11 * kS, "base_link", {1, 2, 3, 4, 5}));
  bag->Add(2, Odometry(13 * kS, 3, 0, 0.3));
  bag->Add(1, Scan(11 * kS, "base_link", {1, 2, 3, 4, 5}));  // repeats a stamp: skipped
  bag->Add(1, "truncated");
  auto feed = BagLaserFeed::Create(std::move(bag), {});
  ASSERT_TRUE(feed.ok()) << feed.status();
  const std::vector<adapters::LaserSample> samples = ReadAll(**feed);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_DOUBLE_EQ(samples[0].stamp, 11.0);
  EXPECT_NEAR(samples[0].odom.x, 1.0, 1e-12);  // a third of the way from 10 s to 13 s
  EXPECT_NEAR(samples[0].odom.theta, 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(samples[1].stamp, 12.0);
  EXPECT_NEAR(samples[1].odom.x, 2.0, 1e-12);
  // Below range_min (0.1) or above range_max (4): no reading.
  EXPECT_TRUE(std::isnan(samples[1].ranges[1]));
  EXPECT_TRUE(std::isnan(samples[1].ranges[3]));
  EXPECT_FLOAT_EQ(samples[1].ranges[4], 2.0f);
  EXPECT_DOUBLE_EQ(samples[1].no_return_range, 4.0);
  EXPECT_DOUBLE_EQ(samples[1].angle_min, -1.0);
  EXPECT_DOUBLE_EQ(samples[1].angle_increment, 0.5);

  const adapters::LaserSourceCounts counts = (*feed)->counts();
  EXPECT_EQ(counts.laser_lines, 4);
  EXPECT_EQ(counts.reordered_lines, 2);
  EXPECT_EQ(counts.skipped_stamps, 1);
  EXPECT_EQ(counts.malformed_lines, 1);
  EXPECT_EQ((*feed)->skipped_no_odometry(), 1);
  const std::vector<std::string> warnings = (*feed)->Warnings();
  const std::string all = ::testing::PrintToString(warnings);
  EXPECT_THAT(all, HasSubstr("could not be decoded"));
  EXPECT_THAT(all, HasSubstr("topic /scan (sensor_msgs/LaserScan, ros1): field 'header.stamp'"));
  EXPECT_THAT(all, HasSubstr("1 scan(s) with no odometry"));
  EXPECT_THAT(all, HasSubstr("1 scan(s) whose header stamp did not increase"));
}

TEST(BagLaserFeedTest, TfChainGivesOdometryAndStaticMounting) {
  auto bag = std::make_unique<FakeBag>();
  bag->AddConnection(1, "/scan", "sensor_msgs/LaserScan");
  bag->AddConnection(2, "/tf", "tf/tfMessage");  // the old type, same layout
  bag->AddConnection(3, "/tf_static", "tf2_msgs/TFMessage");
  bag->Add(3, Tf(0, {{"base_footprint", "base_link", 0, 0, 0}, {"base_link", "laser", 0.2, 0.1,
                                                                  M_PI / 2}}));
  for (int i = 0; i <= 4; ++i) {
    bag->Add(2, Tf(i * kS, {{"map", "odom", 5, 5, 1}, {"odom", "base_footprint", 1.0 * i, 0, 0}}));
    bag->Add(1, Scan(i * kS + kS / 2, "laser", {1, 2}));
  }
  auto feed = BagLaserFeed::Create(std::move(bag), {});
  ASSERT_TRUE(feed.ok()) << feed.status();
  const std::vector<adapters::LaserSample> samples = ReadAll(**feed);
  // The last scan (4.5 s) is 0.5 s after the last transform: held.
  ASSERT_EQ(samples.size(), 5u);
  EXPECT_NEAR(samples[0].odom.x, 0.5, 1e-12);
  EXPECT_NEAR(samples[4].odom.x, 4.0, 1e-12);
  EXPECT_EQ((*feed)->base_frame(), "base_footprint");
  EXPECT_EQ((*feed)->odom_frame(), "odom");
  EXPECT_NEAR((*feed)->LaserMount().x, 0.2, 1e-12);
  EXPECT_NEAR((*feed)->LaserMount().y, 0.1, 1e-12);
  EXPECT_NEAR((*feed)->LaserMount().theta, M_PI / 2, 1e-12);
}

TEST(BagLaserFeedTest, TopicChoiceErrorsNameTheCandidatesAndTheFlag) {
  std::vector<bags::BagConnection> connections;
  auto add = [&](int id, const std::string& topic, const std::string& type,
                 bags::MessageEncoding encoding = bags::MessageEncoding::kCdr) {
    bags::BagConnection c;
    c.id = id;
    c.topic = topic;
    c.type = type;
    c.encoding = encoding;
    c.encoding_name = encoding == bags::MessageEncoding::kOther ? "json" : "cdr";
    connections.push_back(c);
  };
  add(1, "/scan", "sensor_msgs/LaserScan");
  add(2, "/odom", "nav_msgs/Odometry");
  add(3, "/ground_truth", "nav_msgs/Odometry");
  add(4, "/tf", "tf2_msgs/TFMessage");
  add(5, "/points", "sensor_msgs/PointCloud2");
  add(6, "/scan_json", "sensor_msgs/LaserScan", bags::MessageEncoding::kOther);

  auto two_odometry = ChooseLaserTopics(connections, "/scan", "");
  EXPECT_THAT(two_odometry.status().message(),
              HasSubstr("2 nav_msgs/Odometry topics: /odom, /ground_truth; choose one with "
                        "--odom-topic"));
  auto chosen = ChooseLaserTopics(connections, "scan", "/ground_truth");  // '/' optional
  ASSERT_TRUE(chosen.ok()) << chosen.status();
  EXPECT_EQ(chosen->scan_topic, "/scan");
  EXPECT_EQ(chosen->odom_topic, "/ground_truth");
  EXPECT_EQ(chosen->formats.at(1), WireFormat::kCdr);
  auto tf = ChooseLaserTopics(connections, "/scan", "tf");
  ASSERT_TRUE(tf.ok());
  EXPECT_EQ(tf->odometry, OdometrySource::kTf);
  EXPECT_THAT(ChooseLaserTopics(connections, "/points", "tf").status().message(),
              HasSubstr("topic /points is sensor_msgs/PointCloud2, not sensor_msgs/LaserScan"));
  EXPECT_THAT(ChooseLaserTopics(connections, "/nope", "tf").status().message(),
              HasSubstr("no such topic; its sensor_msgs/LaserScan topics: /scan, /scan_json"));
  EXPECT_THAT(ChooseLaserTopics(connections, "/scan_json", "tf").status().message(),
              HasSubstr("encoded as 'json'"));
  EXPECT_THAT(ChooseLaserTopics(connections, "", "tf").status().message(),
              HasSubstr("2 sensor_msgs/LaserScan topics"));
}

}  // namespace
}  // namespace waymark::ros
