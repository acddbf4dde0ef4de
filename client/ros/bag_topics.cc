#include "client/ros/bag_topics.h"

#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/ros/ros_messages.h"

namespace waymark::ros {
namespace {

// "/scan" and "scan" are one topic (ROS 1 bags write the slash, some tools do not).
std::string_view Bare(std::string_view topic) { return FrameName(topic); }

// The distinct topics of `connections` of type `type`, in the bag's order.
std::vector<std::string> TopicsOfType(const std::vector<bags::BagConnection>& connections,
                                      RosType type) {
  std::vector<std::string> topics;
  std::set<std::string> seen;
  for (const bags::BagConnection& c : connections) {
    if (RosTypeOf(c.type) == type && seen.insert(c.topic).second) topics.push_back(c.topic);
  }
  return topics;
}

const bags::BagConnection* FindTopic(const std::vector<bags::BagConnection>& connections,
                                     const std::string& topic) {
  for (const bags::BagConnection& c : connections) {
    if (Bare(c.topic) == Bare(topic)) return &c;
  }
  return nullptr;
}

std::string List(const std::vector<std::string>& topics) {
  return topics.empty() ? "none" : absl::StrJoin(topics, ", ");
}

// Adds every connection on `topic` (several publishers may share one) to `ids`; an encoding this
// replay does not decode is an error naming the topic.
absl::Status AddConnections(const std::vector<bags::BagConnection>& connections,
                            const std::string& topic, std::vector<int>* ids,
                            LaserTopics* topics) {
  for (const bags::BagConnection& c : connections) {
    if (Bare(c.topic) != Bare(topic)) continue;
    if (c.encoding == bags::MessageEncoding::kOther) {
      return absl::InvalidArgumentError(absl::StrCat(
          "topic ", c.topic, " (", c.type, ") is encoded as '", c.encoding_name,
          "'; only ROS 1 and CDR messages are decoded"));
    }
    ids->push_back(c.id);
    topics->formats[c.id] =
        c.encoding == bags::MessageEncoding::kRos1 ? WireFormat::kRos1 : WireFormat::kCdr;
    topics->types[c.id] = c.type;
  }
  return absl::OkStatus();
}

// A topic the user named must be of `wanted`.
absl::Status CheckNamedTopic(const std::vector<bags::BagConnection>& connections,
                             const std::string& flag, const std::string& topic, RosType wanted,
                             const char* wanted_name) {
  const bags::BagConnection* c = FindTopic(connections, topic);
  if (c == nullptr) {
    return absl::NotFoundError(absl::StrCat(flag, " ", topic, ": the bag has no such topic; its ",
                                            wanted_name, " topics: ",
                                            List(TopicsOfType(connections, wanted))));
  }
  if (RosTypeOf(c->type) != wanted) {
    return absl::InvalidArgumentError(absl::StrCat(flag, " ", topic, ": topic ", c->topic, " is ",
                                                   c->type, ", not ", wanted_name));
  }
  return absl::OkStatus();
}

}  // namespace

std::string DescribeTopics(const std::vector<bags::BagConnection>& connections) {
  std::vector<std::string> topics;
  std::set<std::string> seen;
  for (const bags::BagConnection& c : connections) {
    if (seen.insert(c.topic).second) topics.push_back(absl::StrCat(c.topic, " (", c.type, ")"));
  }
  return List(topics);
}

absl::StatusOr<LaserTopics> ChooseLaserTopics(const std::vector<bags::BagConnection>& connections,
                                              const std::string& scan_topic,
                                              const std::string& odom_topic) {
  LaserTopics chosen;
  // The scans.
  if (!scan_topic.empty()) {
    if (absl::Status s = CheckNamedTopic(connections, "--scan-topic", scan_topic,
                                         RosType::kLaserScan, "sensor_msgs/LaserScan");
        !s.ok()) {
      return s;
    }
    chosen.scan_topic = FindTopic(connections, scan_topic)->topic;
  } else {
    const std::vector<std::string> scans = TopicsOfType(connections, RosType::kLaserScan);
    if (scans.empty()) {
      return absl::NotFoundError(absl::StrCat("the bag has no sensor_msgs/LaserScan topic; its "
                                              "topics: ",
                                              DescribeTopics(connections)));
    }
    if (scans.size() > 1) {
      return absl::InvalidArgumentError(absl::StrCat(
          "the bag has ", scans.size(), " sensor_msgs/LaserScan topics: ", List(scans),
          "; choose one with --scan-topic"));
    }
    chosen.scan_topic = scans.front();
  }
  if (absl::Status s =
          AddConnections(connections, chosen.scan_topic, &chosen.scan_connections, &chosen);
      !s.ok()) {
    return s;
  }

  // TF: /tf for odometry (and mountings published there), /tf_static for mountings.
  for (const bags::BagConnection& c : connections) {
    if (RosTypeOf(c.type) != RosType::kTfMessage) continue;
    if (Bare(c.topic) == "tf") {
      if (absl::Status s = AddConnections(connections, c.topic, &chosen.tf_connections, &chosen);
          !s.ok()) {
        return s;
      }
    } else if (Bare(c.topic) == "tf_static") {
      if (absl::Status s =
              AddConnections(connections, c.topic, &chosen.tf_static_connections, &chosen);
          !s.ok()) {
        return s;
      }
    }
  }
  // AddConnections walks every connection of the topic: one pass per topic is enough.
  auto dedupe = [](std::vector<int>& ids) {
    std::set<int> seen;
    std::vector<int> kept;
    for (int id : ids) {
      if (seen.insert(id).second) kept.push_back(id);
    }
    ids = kept;
  };
  dedupe(chosen.tf_connections);
  dedupe(chosen.tf_static_connections);

  // The odometry.
  const std::vector<std::string> odometry_topics = TopicsOfType(connections, RosType::kOdometry);
  if (odom_topic == kOdomNone) {
    chosen.odometry = OdometrySource::kNone;
  } else if (odom_topic == kOdomFromTf) {
    if (chosen.tf_connections.empty()) {
      return absl::NotFoundError(absl::StrCat(
          "--odom-topic tf: the bag has no /tf topic (tf2_msgs/TFMessage or tf/tfMessage); its "
          "nav_msgs/Odometry topics: ",
          List(odometry_topics)));
    }
    chosen.odometry = OdometrySource::kTf;
  } else if (!odom_topic.empty()) {
    if (absl::Status s = CheckNamedTopic(connections, "--odom-topic", odom_topic,
                                         RosType::kOdometry, "nav_msgs/Odometry");
        !s.ok()) {
      return s;
    }
    chosen.odometry = OdometrySource::kOdometryTopic;
    chosen.odom_topic = FindTopic(connections, odom_topic)->topic;
  } else if (odometry_topics.size() == 1) {
    chosen.odometry = OdometrySource::kOdometryTopic;
    chosen.odom_topic = odometry_topics.front();
  } else if (odometry_topics.size() > 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the bag has ", odometry_topics.size(), " nav_msgs/Odometry topics: ",
        List(odometry_topics), "; choose one with --odom-topic (or --odom-topic tf for the odom "
        "-> base chain of /tf)"));
  } else if (!chosen.tf_connections.empty()) {
    chosen.odometry = OdometrySource::kTf;
  } else {
    return absl::NotFoundError(absl::StrCat(
        "the bag has no odometry: no nav_msgs/Odometry topic and no /tf (its topics: ",
        DescribeTopics(connections),
        "); --odom-topic none replays the scans with the robot standing still at the origin, so "
        "the map rests on scan matching alone"));
  }
  if (chosen.odometry == OdometrySource::kOdometryTopic) {
    if (absl::Status s =
            AddConnections(connections, chosen.odom_topic, &chosen.odom_connections, &chosen);
        !s.ok()) {
      return s;
    }
  }
  return chosen;
}

}  // namespace waymark::ros
