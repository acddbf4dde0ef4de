#include "client/ros/frame_tree.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace waymark::ros {
namespace {

double WrapAngle(double angle) { return std::remainder(angle, 2 * M_PI); }

std::string Frame(const std::string& id) { return std::string(FrameName(id)); }

}  // namespace

cli::Pose2 Compose2(const cli::Pose2& a, const cli::Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, WrapAngle(a.theta + b.theta)};
}

cli::Pose2 Inverse2(const cli::Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, WrapAngle(-a.theta)};
}

cli::Pose2 Interpolate2(const cli::Pose2& a, const cli::Pose2& b, double t) {
  return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y),
          WrapAngle(a.theta + t * WrapAngle(b.theta - a.theta))};
}

cli::Pose2 PlanarPose(const Vector3& translation, const Quaternion& rotation) {
  return {translation.x, translation.y, YawOf(rotation)};
}

double TiltOf(const Quaternion& q) {
  const double roll =
      std::atan2(2.0 * (q.w * q.x + q.y * q.z), 1.0 - 2.0 * (q.x * q.x + q.y * q.y));
  const double sin_pitch = std::clamp(2.0 * (q.w * q.y - q.z * q.x), -1.0, 1.0);
  return std::max(std::abs(roll), std::abs(std::asin(sin_pitch)));
}

void PoseHistory::Add(int64_t stamp_ns, const cli::Pose2& pose) {
  if (samples_.empty() || stamp_ns > samples_.back().first) {
    samples_.emplace_back(stamp_ns, pose);
  } else {
    auto at = std::lower_bound(
        samples_.begin(), samples_.end(), stamp_ns,
        [](const std::pair<int64_t, cli::Pose2>& s, int64_t t) { return s.first < t; });
    if (at != samples_.end() && at->first == stamp_ns) {
      at->second = pose;
      return;
    }
    ++reordered_;
    samples_.insert(at, {stamp_ns, pose});
  }
  if (samples_.size() > kMaxSamples) {
    samples_.pop_front();
    ++dropped_;
  }
}

std::optional<cli::Pose2> PoseHistory::At(int64_t stamp_ns, int64_t hold_ns) const {
  if (samples_.empty() || stamp_ns < samples_.front().first) return std::nullopt;
  if (stamp_ns >= samples_.back().first) {
    if (stamp_ns - samples_.back().first > hold_ns) return std::nullopt;
    return samples_.back().second;
  }
  auto after = std::upper_bound(
      samples_.begin(), samples_.end(), stamp_ns,
      [](int64_t t, const std::pair<int64_t, cli::Pose2>& s) { return t < s.first; });
  auto before = std::prev(after);
  if (before->first == stamp_ns) return before->second;
  const double t = static_cast<double>(stamp_ns - before->first) /
                   static_cast<double>(after->first - before->first);
  return Interpolate2(before->second, after->second, t);
}

void PoseHistory::PruneBefore(int64_t stamp_ns) {
  while (samples_.size() >= 2 && samples_[1].first <= stamp_ns) samples_.pop_front();
}

void FrameTree::AddStatic(const TransformStampedMsg& transform) {
  static_[Frame(transform.child_frame_id)] = {
      Frame(transform.header.frame_id), PlanarPose(transform.translation, transform.rotation),
      TiltOf(transform.rotation)};
}

void FrameTree::AddDynamic(const TransformStampedMsg& transform) {
  Moving& moving = moving_[Frame(transform.child_frame_id)];
  const std::string parent = Frame(transform.header.frame_id);
  if (std::find(moving.parents.begin(), moving.parents.end(), parent) == moving.parents.end()) {
    moving.parents.push_back(parent);
  }
  moving.latest = {parent, PlanarPose(transform.translation, transform.rotation),
                   TiltOf(transform.rotation)};
  moving.history.Add(transform.header.stamp_ns, moving.latest.pose);
}

const FrameTree::Edge* FrameTree::FixedEdge(const std::string& child, bool allow_latest) const {
  if (auto it = static_.find(child); it != static_.end()) return &it->second;
  if (!allow_latest) return nullptr;
  if (auto it = moving_.find(child); it != moving_.end() && it->second.parents.size() == 1) {
    return &it->second.latest;
  }
  return nullptr;
}

std::string FrameTree::StaticRoot(const std::string& frame) const {
  std::string at = frame;
  std::set<std::string> seen;
  while (seen.insert(at).second) {
    const Edge* edge = FixedEdge(at, /*allow_latest=*/false);
    if (edge == nullptr) break;
    at = edge->parent;
  }
  return at;
}

absl::StatusOr<cli::Pose2> FrameTree::FixedChain(const std::string& ancestor,
                                                 const std::string& child,
                                                 bool allow_latest) const {
  cli::Pose2 pose;  // child in `at`
  std::string at = child;
  std::set<std::string> seen;
  while (at != ancestor) {
    if (!seen.insert(at).second) {
      return absl::FailedPreconditionError(absl::StrCat("the TF tree has a cycle through '", at,
                                                        "'"));
    }
    const Edge* edge = FixedEdge(at, allow_latest);
    if (edge == nullptr) {
      return absl::NotFoundError(absl::StrCat("no transform from '", ancestor, "' to '", child,
                                              "': '", at, "' has no fixed parent"));
    }
    pose = Compose2(edge->pose, pose);
    at = edge->parent;
  }
  return pose;
}

double FrameTree::ChainTilt(const std::string& ancestor, const std::string& child) const {
  double tilt = 0;
  std::string at = child;
  std::set<std::string> seen;
  while (at != ancestor && seen.insert(at).second) {
    const Edge* edge = FixedEdge(at, /*allow_latest=*/true);
    if (edge == nullptr) break;
    tilt = std::max(tilt, edge->tilt);
    at = edge->parent;
  }
  return tilt;
}

std::vector<std::string> FrameTree::DynamicParents(const std::string& child) const {
  auto it = moving_.find(child);
  return it == moving_.end() ? std::vector<std::string>{} : it->second.parents;
}

PoseHistory* FrameTree::History(const std::string& child) {
  auto it = moving_.find(child);
  return it == moving_.end() ? nullptr : &it->second.history;
}

std::string FrameTree::DescribeDynamic() const {
  std::vector<std::string> edges;
  for (const auto& [child, moving] : moving_) {
    for (const std::string& parent : moving.parents) edges.push_back(parent + " -> " + child);
  }
  return edges.empty() ? "none" : absl::StrJoin(edges, ", ");
}

std::string FrameTree::DescribeStatic() const {
  std::vector<std::string> edges;
  for (const auto& [child, edge] : static_) edges.push_back(edge.parent + " -> " + child);
  return edges.empty() ? "none" : absl::StrJoin(edges, ", ");
}

void FrameTree::PruneBefore(int64_t stamp_ns) {
  for (auto& [child, moving] : moving_) moving.history.PruneBefore(stamp_ns);
}

}  // namespace waymark::ros
