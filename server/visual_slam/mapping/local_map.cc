#include "server/visual_slam/mapping/local_map.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "server/visual_slam/geometry/pose_algebra.h"
#include "server/visual_slam/pose_io.h"

namespace waymark::visual_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Bounds on what Load accepts (far above any real window).
constexpr uint32_t kMaxSavedKeyframes = 1000;
constexpr uint32_t kMaxSavedFeatures = 100000;
constexpr uint32_t kMaxSavedPoints = 1000000;

// The point closest to two rays (midpoint method), or nullopt for near-parallel rays.
std::optional<Eigen::Vector3d> Midpoint(const Eigen::Vector3d& o1, const Eigen::Vector3d& d1,
                                        const Eigen::Vector3d& o2, const Eigen::Vector3d& d2) {
  const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2);
  const Eigen::Vector3d w = o1 - o2;
  const double denominator = a * c - b * b;
  if (std::abs(denominator) < 1e-12) return std::nullopt;
  const double s = (b * d2.dot(w) - c * d1.dot(w)) / denominator;
  const double u = (a * d2.dot(w) - b * d1.dot(w)) / denominator;
  return 0.5 * ((o1 + s * d1) + (o2 + u * d2));
}

}  // namespace

LocalMap::LocalMap(const LocalMapOptions& options, bool monocular)
    : options_(options), monocular_(monocular) {}

void LocalMap::Admit(int64_t id, int feature, int64_t track) {
  if (track < 0) return;
  for (Keyframe& keyframe : keyframes_) {
    if (keyframe.id != id) continue;
    if (feature >= 0 && feature < static_cast<int>(keyframe.track.size())) {
      keyframe.track[feature] = track;
    }
    return;
  }
}

std::vector<int64_t> LocalMap::AddKeyframe(int64_t id, const Pose& pose,
                                           const FrameFeatures& features,
                                           const std::vector<int64_t>& tracks,
                                           const std::vector<bool>& in_map) {
  Keyframe keyframe;
  keyframe.id = id;
  keyframe.pose = pose;
  keyframe.normalized = features.normalized;
  keyframe.depth = features.depth;
  keyframe.track.assign(features.size(), -1);
  std::vector<int64_t> assigned(features.size(), -1);
  for (int i = 0; i < features.size(); ++i) {
    assigned[i] = tracks[i] >= 0 ? tracks[i] : next_track_++;
    if (in_map[i]) keyframe.track[i] = assigned[i];
  }
  keyframes_.push_back(std::move(keyframe));
  while (static_cast<int>(keyframes_.size()) > options_.window) keyframes_.pop_front();
  // Points no keyframe of the window sees any more leave with it.
  if (points_.size() > 4 * 2000) {
    std::unordered_map<int64_t, Eigen::Vector3d> kept;
    for (const Keyframe& k : keyframes_) {
      for (int64_t t : k.track) {
        auto it = points_.find(t);
        if (t >= 0 && it != points_.end()) kept.insert(*it);
      }
    }
    points_.swap(kept);
  }
  return assigned;
}

std::optional<Eigen::Vector3d> LocalMap::InitialPoint(
    const std::vector<std::pair<const Keyframe*, int>>& seen) const {
  if (!monocular_) {
    for (const auto& [keyframe, i] : seen) {
      if (!keyframe->depth[i]) continue;
      const Eigen::Vector3d in_camera =
          *keyframe->depth[i] *
          Eigen::Vector3d(keyframe->normalized[i].x(), keyframe->normalized[i].y(), 1.0);
      return keyframe->pose.R * in_camera + keyframe->pose.t;
    }
    return std::nullopt;
  }
  // The two observations farthest apart in position give the best-conditioned triangulation.
  const auto& [first, i] = seen.front();
  const auto& [last, j] = seen.back();
  const Eigen::Vector3d d1 =
      first->pose.R * Eigen::Vector3d(first->normalized[i].x(), first->normalized[i].y(), 1.0);
  const Eigen::Vector3d d2 =
      last->pose.R * Eigen::Vector3d(last->normalized[j].x(), last->normalized[j].y(), 1.0);
  const double cosine = d1.normalized().dot(d2.normalized());
  if (cosine > std::cos(options_.min_parallax_deg * kPi / 180)) return std::nullopt;
  std::optional<Eigen::Vector3d> point = Midpoint(first->pose.t, d1, last->pose.t, d2);
  if (!point) return std::nullopt;
  for (const auto& [keyframe, k] : seen) {
    const Eigen::Vector3d in_camera = keyframe->pose.R.transpose() * (*point - keyframe->pose.t);
    if (in_camera.z() <= 0) return std::nullopt;
  }
  return point;
}

std::optional<BundleJob> LocalMap::MakeJob() const {
  const int fixed = monocular_ ? 2 : 1;
  if (static_cast<int>(keyframes_.size()) <= fixed) return std::nullopt;
  BundleJob job;
  // Observations per track, in keyframe order.
  std::map<int64_t, std::vector<std::pair<const Keyframe*, int>>> seen;
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    const Keyframe& keyframe = keyframes_[k];
    job.problem.cameras.push_back({keyframe.pose, static_cast<int>(k) < fixed});
    job.keyframe_ids.push_back(keyframe.id);
    for (size_t i = 0; i < keyframe.track.size(); ++i) {
      if (keyframe.track[i] >= 0)
        seen[keyframe.track[i]].push_back({&keyframe, static_cast<int>(i)});
    }
  }
  std::unordered_map<int64_t, int> camera_of;
  for (size_t k = 0; k < job.keyframe_ids.size(); ++k) camera_of[job.keyframe_ids[k]] = k;
  for (const auto& [track, observations] : seen) {
    if (static_cast<int>(observations.size()) < options_.min_observations) continue;
    std::optional<Eigen::Vector3d> point;
    if (auto it = points_.find(track); it != points_.end()) {
      point = it->second;
    } else {
      point = InitialPoint(observations);
    }
    if (!point) continue;
    const int index = static_cast<int>(job.problem.points.size());
    job.problem.points.push_back(*point);
    job.point_tracks.push_back(track);
    for (const auto& [keyframe, i] : observations) {
      BundleObservation o;
      o.camera = camera_of.at(keyframe->id);
      o.point = index;
      o.normalized = keyframe->normalized[i];
      o.depth = keyframe->depth[i];
      job.problem.observations.push_back(o);
      job.observation_features.push_back({keyframe->id, i});
    }
  }
  if (job.problem.points.size() < 20) return std::nullopt;
  return job;
}

void LocalMap::Apply(const BundleJob& job, const BundleResult& result) {
  std::unordered_map<int64_t, Keyframe*> by_id;
  for (Keyframe& keyframe : keyframes_) by_id[keyframe.id] = &keyframe;
  for (size_t c = 0; c < job.keyframe_ids.size(); ++c) {
    if (auto it = by_id.find(job.keyframe_ids[c]); it != by_id.end()) {
      it->second->pose = result.cameras[c];
    }
  }
  // Keyframes made while it ran were placed from the newest one it adjusted: they follow it.
  const int64_t newest = job.keyframe_ids.back();
  const Pose& newest_before = job.problem.cameras.back().pose;
  const Pose& newest_after = result.cameras.back();
  for (Keyframe& keyframe : keyframes_) {
    if (keyframe.id > newest) {
      keyframe.pose = PoseAfter(newest_after, MotionBetween(newest_before, keyframe.pose));
    }
  }
  // A track with an outlier observation loses that observation; its point is kept only when most
  // of its observations agree with it.
  std::vector<int> inliers(job.point_tracks.size(), 0), total(job.point_tracks.size(), 0);
  for (size_t k = 0; k < job.problem.observations.size(); ++k) {
    const int point = job.problem.observations[k].point;
    ++total[point];
    if (!result.outlier[k]) {
      ++inliers[point];
      continue;
    }
    const auto& [keyframe_id, feature] = job.observation_features[k];
    if (auto it = by_id.find(keyframe_id); it != by_id.end()) it->second->track[feature] = -1;
  }
  for (size_t p = 0; p < job.point_tracks.size(); ++p) {
    if (2 * inliers[p] > total[p] && inliers[p] >= 2) {
      points_[job.point_tracks[p]] = result.points[p];
    } else {
      points_.erase(job.point_tracks[p]);
    }
  }
}

std::optional<Pose> LocalMap::PoseOf(int64_t id) const {
  for (const Keyframe& keyframe : keyframes_) {
    if (keyframe.id == id) return keyframe.pose;
  }
  return std::nullopt;
}

std::optional<Eigen::Vector3d> LocalMap::Point(int64_t track) const {
  auto it = points_.find(track);
  if (it == points_.end()) return std::nullopt;
  return it->second;
}

void LocalMap::Save(BinaryWriter& out) const {
  out.Put<int64_t>(next_track_);
  out.Put<uint32_t>(static_cast<uint32_t>(keyframes_.size()));
  for (const Keyframe& k : keyframes_) {
    out.Put<int64_t>(k.id);
    PutPose(out, k.pose);
    out.Put<uint32_t>(static_cast<uint32_t>(k.normalized.size()));
    for (size_t i = 0; i < k.normalized.size(); ++i) {
      out.Put<double>(k.normalized[i].x());
      out.Put<double>(k.normalized[i].y());
      out.Put<uint8_t>(k.depth[i].has_value());
      out.Put<double>(k.depth[i].value_or(0));
      out.Put<int64_t>(k.track[i]);
    }
  }
  // Sorted by track, so that equal maps save to equal bytes.
  std::map<int64_t, Eigen::Vector3d> sorted(points_.begin(), points_.end());
  out.Put<uint32_t>(static_cast<uint32_t>(sorted.size()));
  for (const auto& [track, point] : sorted) {
    out.Put<int64_t>(track);
    for (int i = 0; i < 3; ++i) out.Put<double>(point(i));
  }
}

bool LocalMap::Load(BinaryReader& in) {
  int64_t next_track = 0;
  uint32_t count = 0;
  if (!in.Get(&next_track) || next_track < 0 || !in.Get(&count) || count > kMaxSavedKeyframes) {
    return false;
  }
  std::deque<Keyframe> keyframes;
  for (uint32_t k = 0; k < count; ++k) {
    Keyframe keyframe;
    uint32_t n = 0;
    if (!in.Get(&keyframe.id) || !GetPose(in, &keyframe.pose) || !in.Get(&n) ||
        n > kMaxSavedFeatures) {
      return false;
    }
    for (uint32_t i = 0; i < n; ++i) {
      double x = 0, y = 0, depth = 0;
      uint8_t has_depth = 0;
      int64_t track = 0;
      if (!in.Get(&x) || !in.Get(&y) || !in.Get(&has_depth) || !in.Get(&depth) || !in.Get(&track) ||
          !std::isfinite(x) || !std::isfinite(y) ||
          (has_depth && !(std::isfinite(depth) && depth > 0)) || track < -1 ||
          track >= next_track) {
        return false;
      }
      keyframe.normalized.emplace_back(x, y);
      keyframe.depth.push_back(has_depth ? std::optional<double>(depth) : std::nullopt);
      keyframe.track.push_back(track);
    }
    keyframes.push_back(std::move(keyframe));
  }
  if (!in.Get(&count) || count > kMaxSavedPoints) return false;
  std::unordered_map<int64_t, Eigen::Vector3d> points;
  for (uint32_t p = 0; p < count; ++p) {
    int64_t track = 0;
    Eigen::Vector3d point;
    if (!in.Get(&track) || !in.Get(&point.x()) || !in.Get(&point.y()) || !in.Get(&point.z()) ||
        track < 0 || track >= next_track || !point.allFinite()) {
      return false;
    }
    points[track] = point;
  }
  next_track_ = next_track;
  keyframes_ = std::move(keyframes);
  while (static_cast<int>(keyframes_.size()) > options_.window) keyframes_.pop_front();
  points_ = std::move(points);
  return true;
}

}  // namespace waymark::visual_slam
