#include "client/ros/bag_laser_feed.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::ros {
namespace {

constexpr int64_t kNsPerS = 1000000000;

bool MapLike(const std::string& frame) {
  return frame == "map" || frame == "world" || frame == "earth";
}

bool Contains(const std::vector<int>& ids, int id) {
  return std::find(ids.begin(), ids.end(), id) != ids.end();
}

std::string PoseText(const cli::Pose2& p) {
  return absl::StrFormat("x %.3f m, y %.3f m, theta %.4f rad", p.x, p.y, p.theta);
}

// The scan as a replay sends it (see the file comment).
adapters::LaserSample SampleOf(const LaserScanMsg& scan) {
  adapters::LaserSample sample;
  sample.stamp = static_cast<double>(scan.header.stamp_ns) / 1e9;
  const bool max_known = std::isfinite(scan.range_max) && scan.range_max > 0;
  sample.no_return_range = max_known ? scan.range_max : 0.0;
  sample.ranges.reserve(scan.ranges.size());
  for (float r : scan.ranges) {
    const bool valid = !(r < scan.range_min) && !(max_known && r > scan.range_max);
    sample.ranges.push_back(valid ? r : std::numeric_limits<float>::quiet_NaN());
  }
  sample.angle_min = scan.angle_min;
  sample.angle_increment = scan.angle_increment;
  if (sample.angle_increment < 0 && !sample.ranges.empty()) {
    sample.angle_min += sample.angle_increment * static_cast<double>(sample.ranges.size() - 1);
    sample.angle_increment = -sample.angle_increment;
    std::reverse(sample.ranges.begin(), sample.ranges.end());
  }
  return sample;
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagLaserFeed>> BagLaserFeed::Create(
    std::unique_ptr<bags::BagReader> reader, const BagLaserOptions& options) {
  absl::StatusOr<LaserTopics> topics =
      ChooseLaserTopics(reader->connections(), options.scan_topic, options.odom_topic);
  if (!topics.ok()) return topics.status();
  std::vector<int> wanted = topics->scan_connections;
  for (const std::vector<int>* ids : {&topics->odom_connections, &topics->tf_connections,
                                      &topics->tf_static_connections}) {
    wanted.insert(wanted.end(), ids->begin(), ids->end());
  }
  reader->Select(wanted);
  return std::unique_ptr<BagLaserFeed>(
      new BagLaserFeed(std::move(reader), *std::move(topics), options));
}

BagLaserFeed::BagLaserFeed(std::unique_ptr<bags::BagReader> reader, LaserTopics topics,
                           BagLaserOptions options)
    : reader_(std::move(reader)), topics_(std::move(topics)), options_(std::move(options)) {}

bool BagLaserFeed::Later(const LaserScanMsg& a, const LaserScanMsg& b) {
  return a.header.stamp_ns > b.header.stamp_ns;
}

void BagLaserFeed::NoteError(const absl::Status& status) {
  ++malformed_;
  if (first_errors_.size() < kErrorsKept) first_errors_.emplace_back(status.message());
}

absl::StatusOr<bool> BagLaserFeed::ReadOne() {
  bags::BagMessage message;
  absl::StatusOr<bool> more = reader_->Next(&message);
  if (!more.ok() || !*more) return more;
  const int id = message.connection_id;
  auto format = topics_.formats.find(id);
  if (format == topics_.formats.end()) return true;  // not selected (a reader that ignores Select)
  std::string topic;
  for (const bags::BagConnection& c : reader_->connections()) {
    if (c.id == id) topic = c.topic;
  }
  const MessageOrigin origin{topic, topics_.types.at(id)};
  if (Contains(topics_.scan_connections, id)) {
    absl::StatusOr<LaserScanMsg> scan = DecodeLaserScan(format->second, message.data, origin);
    if (!scan.ok()) {
      NoteError(scan.status());
      return true;
    }
    ++scans_read_;
    if (scans_read_ > 1 && scan->header.stamp_ns < max_read_ns_) ++reordered_;
    max_read_ns_ = std::max(max_read_ns_, scan->header.stamp_ns);
    pending_.push_back(*std::move(scan));
    std::push_heap(pending_.begin(), pending_.end(), Later);
  } else if (Contains(topics_.odom_connections, id)) {
    absl::StatusOr<OdometryMsg> odometry = DecodeOdometry(format->second, message.data, origin);
    if (!odometry.ok()) {
      NoteError(odometry.status());
      return true;
    }
    ++odometry_read_;
    if (odometry_read_ == 1) {
      odom_child_ = std::string(FrameName(odometry->child_frame_id));
      odom_parent_ = std::string(FrameName(odometry->header.frame_id));
    }
    odometry_.Add(odometry->header.stamp_ns,
                  PlanarPose(odometry->position, odometry->orientation));
  } else {
    absl::StatusOr<TfMsg> tf = DecodeTf(format->second, message.data, origin);
    if (!tf.ok()) {
      NoteError(tf.status());
      return true;
    }
    ++tf_read_;
    const bool is_static = Contains(topics_.tf_static_connections, id);
    for (const TransformStampedMsg& t : tf->transforms) {
      if (is_static) {
        frames_.AddStatic(t);
      } else {
        frames_.AddDynamic(t);
      }
    }
  }
  return true;
}

absl::Status BagLaserFeed::SetUp(const LaserScanMsg& first) {
  laser_frame_ = std::string(FrameName(first.header.frame_id));
  switch (topics_.odometry) {
    case OdometrySource::kNone:
      base_frame_ = frames_.StaticRoot(laser_frame_);
      notes_.push_back("no odometry (--odom-topic none): every scan is sent at the origin, so the "
                       "map rests on scan matching alone");
      break;
    case OdometrySource::kOdometryTopic:
      odom_frame_ = odom_parent_;
      base_frame_ = odom_child_.empty() ? frames_.StaticRoot(laser_frame_) : odom_child_;
      if (odom_child_.empty() && odometry_read_ > 0) {
        notes_.push_back(absl::StrCat(
            "the odometry on ", topics_.odom_topic, " has an empty child_frame_id: '",
            base_frame_, "' (the top of the laser frame's static chain) is taken as the robot"));
      }
      break;
    case OdometrySource::kTf: {
      // Up from the laser frame through every edge, to the frame below map/world/earth.
      std::vector<std::string> chain = {laser_frame_};
      std::set<std::string> seen = {laser_frame_};
      while (true) {
        std::string parent;
        const std::string root = frames_.StaticRoot(chain.back());
        if (root != chain.back()) {
          parent = root;
        } else {
          const std::vector<std::string> parents = frames_.DynamicParents(chain.back());
          if (parents.size() > 1) {
            return absl::FailedPreconditionError(absl::StrCat(
                "TF: frame '", chain.back(), "' moves in several parents (",
                frames_.DescribeDynamic(), "); choose an odometry topic with --odom-topic"));
          }
          if (!parents.empty()) parent = parents.front();
        }
        if (parent.empty() || MapLike(parent) || !seen.insert(parent).second) break;
        chain.push_back(parent);
      }
      // The top moving edge of the chain is the odometry.
      for (size_t i = chain.size(); i-- > 1;) {
        const std::string& child = chain[i - 1];
        if (frames_.StaticRoot(child) != child) continue;  // a static edge
        PoseHistory* history = frames_.History(child);
        if (history == nullptr || history->empty()) continue;
        base_frame_ = child;
        odom_frame_ = chain[i];
        tf_odometry_ = history;
        break;
      }
      if (tf_odometry_ == nullptr) {
        return absl::NotFoundError(absl::StrCat(
            "no odometry in TF: no moving transform above the laser frame '", laser_frame_,
            "' (moving: ", frames_.DescribeDynamic(), "; static: ", frames_.DescribeStatic(),
            "); name an odometry topic with --odom-topic, or --odom-topic none"));
      }
      break;
    }
  }
  if (laser_frame_ == base_frame_ || laser_frame_.empty()) {
    mount_ = {};
  } else if (absl::StatusOr<cli::Pose2> mount =
                 frames_.FixedChain(base_frame_, laser_frame_, /*allow_latest=*/true);
             mount.ok()) {
    mount_ = *mount;
    const double tilt = frames_.ChainTilt(base_frame_, laser_frame_);
    if (tilt > kMaxTilt) {
      notes_.push_back(absl::StrFormat(
          "the laser frame '%s' is tilted %.2f rad from '%s': its scans are used as if level",
          laser_frame_, tilt, base_frame_));
    }
  } else {
    mount_ = {};
    notes_.push_back(absl::StrCat("no transform from the robot's frame '", base_frame_,
                                  "' to the laser frame '", laser_frame_,
                                  "' in /tf_static or /tf (static: ", frames_.DescribeStatic(),
                                  "): the laser is taken at the robot's origin"));
  }
  set_up_ = true;
  return absl::OkStatus();
}

absl::StatusOr<bool> BagLaserFeed::Next(adapters::LaserSample* sample) {
  while (true) {
    while (!eof_ && pending_.size() <= kReorderWindow) {
      absl::StatusOr<bool> more = ReadOne();
      if (!more.ok()) return more.status();
      eof_ = !*more;
    }
    if (pending_.empty()) {
      if (scans_returned_ == 0 && malformed_ > 0 && scans_read_ == 0) {
        return absl::InvalidArgumentError(absl::StrCat("no scan on ", topics_.scan_topic,
                                                       " could be decoded; the first error: ",
                                                       first_errors_.front()));
      }
      return false;
    }
    std::pop_heap(pending_.begin(), pending_.end(), Later);
    LaserScanMsg scan = std::move(pending_.back());
    pending_.pop_back();
    if (!set_up_) {
      if (absl::Status s = SetUp(scan); !s.ok()) return s;
    }
    const int64_t stamp = scan.header.stamp_ns;
    if (have_last_ && stamp <= last_stamp_ns_) {
      ++skipped_stamps_;
      continue;
    }
    if (FrameName(scan.header.frame_id) != laser_frame_) ++other_frame_scans_;
    std::optional<cli::Pose2> odom;
    const int64_t hold = static_cast<int64_t>(kOdometryHoldS * kNsPerS);
    switch (topics_.odometry) {
      case OdometrySource::kNone: odom = cli::Pose2{}; break;
      case OdometrySource::kOdometryTopic: odom = odometry_.At(stamp, hold); break;
      case OdometrySource::kTf: odom = tf_odometry_->At(stamp, hold); break;
    }
    if (!odom) {
      ++skipped_no_odometry_;
      continue;
    }
    have_last_ = true;
    last_stamp_ns_ = stamp;
    odometry_.PruneBefore(stamp);
    frames_.PruneBefore(stamp);
    *sample = SampleOf(scan);
    sample->odom = *odom;
    ++scans_returned_;
    return true;
  }
}

adapters::LaserSourceCounts BagLaserFeed::counts() const {
  adapters::LaserSourceCounts counts;
  counts.laser_lines = scans_read_;
  counts.skipped_stamps = skipped_stamps_;
  counts.reordered_lines = reordered_;
  counts.malformed_lines = malformed_;
  counts.odometry_lines = topics_.odometry == OdometrySource::kTf ? tf_read_ : odometry_read_;
  counts.stamps_broken = 2 * skipped_stamps_ > scans_read_;
  return counts;
}

std::vector<std::string> BagLaserFeed::Warnings() const {
  std::vector<std::string> warnings = notes_;
  if (malformed_ > 0) {
    std::string text = absl::StrCat("skipped ", malformed_, " message(s) that could not be decoded");
    for (const std::string& error : first_errors_) absl::StrAppend(&text, "\n  ", error);
    warnings.push_back(text);
  }
  if (skipped_no_odometry_ > 0) {
    warnings.push_back(absl::StrFormat(
        "skipped %d scan(s) with no odometry at their stamp (before the first odometry message, "
        "or more than %.1f s after the last)",
        skipped_no_odometry_, kOdometryHoldS));
  }
  if (skipped_stamps_ > 0 && 2 * skipped_stamps_ <= scans_read_) {
    warnings.push_back(absl::StrCat("skipped ", skipped_stamps_, " scan(s) whose header stamp "
                                    "did not increase (after reordering within ",
                                    kReorderWindow, " scans)"));
  }
  if (other_frame_scans_ > 0) {
    warnings.push_back(absl::StrCat(other_frame_scans_, " scan(s) carry another frame_id than '",
                                    laser_frame_, "' (the first scan's): all use its mounting"));
  }
  if (odometry_.dropped() > 0) {
    warnings.push_back(absl::StrCat("dropped ", odometry_.dropped(),
                                    " odometry message(s) beyond the history's bound"));
  }
  for (const std::string& w : reader_->warnings()) warnings.push_back("bag: " + w);
  return warnings;
}

std::string BagLaserFeed::BrokenStampsWarning() const {
  if (!(2 * skipped_stamps_ > scans_read_)) return "";
  return absl::StrCat("WARNING: ", skipped_stamps_, " of ", scans_read_, " scans on ",
                      topics_.scan_topic,
                      " were skipped because their header stamps do not increase: this bag's "
                      "stamps are broken, and only ",
                      scans_read_ - skipped_stamps_, " scans were used.\n");
}

std::vector<std::pair<std::string, std::string>> BagLaserFeed::Facts() const {
  std::string odometry;
  switch (topics_.odometry) {
    case OdometrySource::kNone: odometry = "none"; break;
    case OdometrySource::kOdometryTopic: odometry = topics_.odom_topic; break;
    case OdometrySource::kTf:
      odometry = absl::StrCat("tf ", odom_frame_, " -> ", base_frame_);
      break;
  }
  return {{"format", options_.format},
          {"scan_topic", topics_.scan_topic},
          {"odometry", odometry},
          {"laser_frame", laser_frame_},
          {"base_frame", base_frame_},
          {"laser_mount", PoseText(mount_)},
          {"skipped_no_odometry", std::to_string(skipped_no_odometry_)}};
}

}  // namespace waymark::ros
