#include "server/service/slam/map_follow_codec.h"

#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace waymark::service {
namespace {

void SetPose(const laser_slam::Pose2& pose, v1::Pose2D* out) {
  out->set_x(pose.x);
  out->set_y(pose.y);
  out->set_theta(pose.theta);
}

bool Finite(const laser_slam::Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

}  // namespace

void SetSample(const laser_slam::OriginSample& sample, v1::MapOriginSample* out) {
  out->set_scan(sample.scan);
  out->set_stamp(sample.stamp);
  SetPose(sample.origin, out->mutable_origin());
  if (sample.matched) SetPose(sample.map_pose, out->mutable_map_pose());
}

std::vector<laser_slam::OriginSample> SamplesOf(const v1::MapTrajectory& trajectory) {
  std::vector<laser_slam::OriginSample> samples;
  for (const v1::MapOriginSample& in : trajectory.origin_samples()) {
    laser_slam::OriginSample sample;
    sample.scan = in.scan();
    sample.stamp = in.stamp();
    sample.origin = laser_slam::Pose2{in.origin().x(), in.origin().y(), in.origin().theta()};
    sample.matched = in.has_map_pose();
    if (sample.matched) {
      sample.map_pose =
          laser_slam::Pose2{in.map_pose().x(), in.map_pose().y(), in.map_pose().theta()};
    }
    samples.push_back(sample);
  }
  return samples;
}

std::string EncodeFollow(const StoredFollow& follow) {
  v1::MapTrajectory trajectory;
  for (const laser_slam::OriginSample& sample : follow.samples) {
    SetSample(sample, trajectory.add_origin_samples());
  }
  *trajectory.mutable_follow() = follow.stats;
  *trajectory.mutable_search() = follow.search;
  return trajectory.SerializeAsString();
}

absl::StatusOr<StoredFollow> DecodeFollow(const std::string& bytes) {
  v1::MapTrajectory trajectory;
  if (!trajectory.ParseFromString(bytes)) {
    return absl::DataLossError("a trajectory's stored follow is not a list of origin samples");
  }
  StoredFollow follow{SamplesOf(trajectory), trajectory.follow(), trajectory.search()};
  for (size_t i = 0; i < follow.samples.size(); ++i) {
    const laser_slam::OriginSample& sample = follow.samples[i];
    if (!std::isfinite(sample.stamp) || !Finite(sample.origin) || !Finite(sample.map_pose) ||
        (i > 0 && sample.stamp < follow.samples[i - 1].stamp)) {
      return absl::DataLossError(
          "a trajectory's stored follow has a sample out of order or not finite");
    }
  }
  return follow;
}

v1::MapMatchStats StatsOf(const laser_slam::FollowProgress& progress) {
  v1::MapMatchStats stats;
  stats.set_tried(static_cast<uint32_t>(progress.attempts));
  stats.set_matched(static_cast<uint32_t>(progress.matched));
  stats.set_weak(static_cast<uint32_t>(progress.weak));
  stats.set_ambiguous(static_cast<uint32_t>(progress.ambiguous));
  return stats;
}

v1::MapMatchStats StatsOf(const laser_slam::TieProgress& progress) {
  v1::MapMatchStats stats;
  stats.set_tried(static_cast<uint32_t>(progress.searches));
  stats.set_matched(static_cast<uint32_t>(progress.matches));
  stats.set_ambiguous(static_cast<uint32_t>(progress.ambiguous));
  // A finished search that found neither a unique match nor a rival found nothing good enough.
  const int weak = progress.searches - progress.matches - progress.ambiguous;
  stats.set_weak(static_cast<uint32_t>(weak > 0 ? weak : 0));
  return stats;
}

v1::MapMatchStats Sum(const v1::MapMatchStats& a, const v1::MapMatchStats& b) {
  v1::MapMatchStats sum;
  sum.set_tried(a.tried() + b.tried());
  sum.set_matched(a.matched() + b.matched());
  sum.set_weak(a.weak() + b.weak());
  sum.set_ambiguous(a.ambiguous() + b.ambiguous());
  return sum;
}

std::string MapTrajectoryWarning(const v1::MapTrajectory& trajectory) {
  if (!trajectory.tied_in()) {
    const v1::MapMatchStats& s = trajectory.search();
    if (s.ambiguous() == 0) return "";
    return absl::StrCat(s.ambiguous(), " of ", s.tried(),
                        " searches found look-alike places (a rival nearly as good as the match): "
                        "not tied in until one place wins");
  }
  std::string warning;
  if (const v1::MapMatchStats& s = trajectory.search(); s.ambiguous() > 0) {
    warning = absl::StrCat("tied in after ", s.ambiguous(), " of its ", s.tried(),
                           " searches found look-alike places: it may be at one of them");
  }
  const v1::MapMatchStats& f = trajectory.follow();
  constexpr uint32_t kFewest = 10;  // fewer attempts say little either way
  if (f.tried() < kFewest || 2 * f.matched() >= f.tried()) return warning;
  return absl::StrCat(warning, warning.empty() ? "" : "; ", "only ", f.matched(), " of ", f.tried(),
                      " follow-up matches held (", f.weak(), " off the map, ", f.ambiguous(),
                      " between look-alike places): between them its map-frame pose drifts with "
                      "its own odometry");
}

}  // namespace waymark::service
