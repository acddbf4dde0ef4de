#ifndef WAYMARK_CLIENT_ROS_BAG_LASER_FEED_H_
#define WAYMARK_CLIENT_ROS_BAG_LASER_FEED_H_

// A bag as a LaserSource (client/datasets/laser_source.h): the scans of one sensor_msgs/LaserScan
// topic, each with the robot's odometry pose at the scan's header stamp, and the laser's mounting
// from TF. Topics are chosen by bag_topics.h.
//
// Time. Scans and odometry are placed by their header stamps, not the record time: real bags have
// header stamps that run ahead of the record time (zaki_urg's subset.bag by 15 s, from another
// machine's clock), and a sensor's messages reach the recorder out of order. Scans are put in
// stamp order within a lookahead of kReorderWindow scans; a scan whose stamp still does not
// increase is skipped and counted, as is a scan with no odometry at its stamp (before the first
// odometry message, or more than kOdometryHoldS after the last one). Odometry is interpolated
// between the two messages around the scan's stamp (linear in x, y, the shorter turn in yaw).
//
// Frames (a leading '/' of ROS 1 frame ids ignored):
//   odometry topic: the base frame is the messages' child_frame_id; when it is empty (Stage bags)
//     the top of the laser frame's static chain is taken as the base;
//   TF: the chain above the laser frame (the scans' header.frame_id) is followed up to the frame
//     below `map`/`world`/`earth` (or the top); the last moving edge on it (odom -> base_link) is
//     the odometry, its child the base frame;
//   the mounting is the base -> laser chain through /tf_static (or the latest /tf value of an
//     edge published there by an old static_transform_publisher); a laser frame that is the base
//     frame is at the origin; with no chain at all the laser is taken at the base's origin, with
//     a warning naming the frames.
//   none (--odom-topic none): every scan at the origin, with a warning.
//
// Scans: ranges below range_min or above range_max become NaN (no reading, as ROS defines them);
// range_max is the no-return range; a negative angle_increment is turned into the same beams in
// increasing order. Messages that cannot be decoded are skipped and counted; the first few errors
// are kept for the warnings, and a bag none of whose scans decode is an error naming the first.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "client/bags/bag_reader.h"
#include "client/datasets/laser_source.h"
#include "client/ros/bag_topics.h"
#include "client/ros/frame_tree.h"
#include "client/ros/ros_messages.h"

namespace waymark::ros {

struct BagLaserOptions {
  std::string scan_topic;  // --scan-topic; empty: the only LaserScan topic
  std::string odom_topic;  // --odom-topic; empty: automatic; "tf"; "none"
  std::string format;      // the bag's format, for the summary ("ROS 1 bag v2.0")
};

class BagLaserFeed : public adapters::LaserSource {
 public:
  static constexpr size_t kReorderWindow = 64;
  static constexpr double kOdometryHoldS = 0.5;
  static constexpr size_t kErrorsKept = 5;

  static absl::StatusOr<std::unique_ptr<BagLaserFeed>> Create(
      std::unique_ptr<bags::BagReader> reader, const BagLaserOptions& options);

  absl::StatusOr<bool> Next(adapters::LaserSample* sample) override;
  cli::Pose2 LaserMount() const override { return mount_; }
  adapters::LaserSourceCounts counts() const override;
  std::vector<std::string> Warnings() const override;
  std::string BrokenStampsWarning() const override;
  std::vector<std::pair<std::string, std::string>> Facts() const override;

  const LaserTopics& topics() const { return topics_; }
  const std::string& laser_frame() const { return laser_frame_; }
  const std::string& base_frame() const { return base_frame_; }
  const std::string& odom_frame() const { return odom_frame_; }
  int64_t skipped_no_odometry() const { return skipped_no_odometry_; }

 private:
  BagLaserFeed(std::unique_ptr<bags::BagReader> reader, LaserTopics topics,
               BagLaserOptions options);

  // Reads one message into the pending scans, the odometry or the frame tree; false at the end.
  absl::StatusOr<bool> ReadOne();
  // Frames, mounting and odometry history, once the first scans are read.
  absl::Status SetUp(const LaserScanMsg& first);
  void NoteError(const absl::Status& status);
  static bool Later(const LaserScanMsg& a, const LaserScanMsg& b);

  std::unique_ptr<bags::BagReader> reader_;
  const LaserTopics topics_;
  const BagLaserOptions options_;

  std::vector<LaserScanMsg> pending_;  // min-heap by header stamp
  bool eof_ = false;
  bool set_up_ = false;
  bool have_last_ = false;
  int64_t last_stamp_ns_ = 0;
  int64_t max_read_ns_ = 0;

  PoseHistory odometry_;            // from the odometry topic
  PoseHistory* tf_odometry_ = nullptr;  // in the frame tree, TF mode
  FrameTree frames_;
  std::string odom_child_;  // the odometry messages' child_frame_id (first one seen)
  std::string odom_parent_;
  std::string laser_frame_;
  std::string base_frame_;
  std::string odom_frame_;
  cli::Pose2 mount_;
  std::vector<std::string> notes_;  // set-up warnings (no mounting found, tilted laser, ...)

  int64_t scans_read_ = 0;
  int64_t scans_returned_ = 0;
  int64_t reordered_ = 0;
  int64_t skipped_stamps_ = 0;
  int64_t skipped_no_odometry_ = 0;
  int64_t odometry_read_ = 0;
  int64_t tf_read_ = 0;
  int64_t malformed_ = 0;
  int64_t other_frame_scans_ = 0;
  std::vector<std::string> first_errors_;
};

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_BAG_LASER_FEED_H_
