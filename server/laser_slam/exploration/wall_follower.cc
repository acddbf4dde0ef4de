#include "server/laser_slam/exploration/wall_follower.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/motion.h"

namespace waymark::laser_slam {
namespace {

constexpr int kMaxHops = 20;
constexpr double kHeadingWeight = 0.3;  // m of position error worth one radian of heading error
// A tracked segment further than this from the robot (it drove elsewhere under optimal control
// since) is given up and a new one chosen (m).
constexpr double kMaxTrackDistance = 3.0;
// Progress that counts (cost units, ~m), the heading error below which the robot faces along its
// line (rad), and the stuck detector: moved less than kStuckDistance over kStuckDecisions.
constexpr double kMinProgress = 0.05;
constexpr double kAligned = 0.35;
constexpr int kStuckDecisions = 8;
// A segment meets ours in a T junction only at more than ~20 degrees; a nearly collinear one
// passing our end is a duplicate or a continuation, not a junction.
constexpr double kMinJunctionSine = 0.34;
constexpr double kStuckDistance = 0.3;

Pose2 EndPoint(const MapSegment& s, int end) {
  return Compose(s.frame, Pose2{end < 0 ? s.left : s.right, 0.0, 0.0});
}

EndpointType EndType(const MapSegment& s, int end) { return end < 0 ? s.left_type : s.right_type; }

}  // namespace

void WallFollower::Reset() {
  tracked_ = 0;
  rounding_ = false;
  turning_ = 0;
  recent_.clear();
}

const MapSegment* WallFollower::Find(const std::vector<MapSegment>& segments,
                                     std::uint64_t id) const {
  for (const MapSegment& s : segments) {
    if (s.id == id) return &s;
  }
  return nullptr;
}

const MapSegment* WallFollower::Adjacent(const std::vector<MapSegment>& segments,
                                         const MapSegment& segment, int direction,
                                         const Eigen::Vector2d& away, int* next_direction) const {
  const Pose2 end_pose = EndPoint(segment, direction);
  const Eigen::Vector2d end(end_pose.x, end_pose.y);
  const Eigen::Vector2d axis(std::cos(segment.frame.theta), std::sin(segment.frame.theta));
  const MapSegment* best = nullptr;
  double best_gap = options_.adjacency;
  for (const MapSegment& other : segments) {
    if (other.id == segment.id) continue;
    const Pose2 pa = EndPoint(other, -1), pb = EndPoint(other, 1);
    const Eigen::Vector2d a(pa.x, pa.y), b(pb.x, pb.y);
    // An L corner: one of its ends is here; leave it by the other end.
    for (const auto& [point, leave] : {std::pair<Eigen::Vector2d, int>{a, 1}, {b, -1}}) {
      const double gap = (point - end).norm();
      if (gap <= best_gap) {
        best_gap = gap;
        best = &other;
        *next_direction = leave;
      }
    }
    // A T junction: it passes here (not along our own line); follow it on the robot's side.
    const Eigen::Vector2d other_axis(std::cos(other.frame.theta), std::sin(other.frame.theta));
    if (std::abs(axis.x() * other_axis.y() - axis.y() * other_axis.x()) < kMinJunctionSine) continue;
    const double gap = PointSegmentDistance(end, a, b);
    if (gap < best_gap) {
      best_gap = gap;
      best = &other;
      *next_direction = other_axis.dot(away) >= 0.0 ? 1 : -1;
    }
  }
  return best;
}

Eigen::Vector2d WallFollower::AwayFromWall(const MapSegment& s, const Pose2& robot) {
  const double side = Relative(s.frame, robot).y >= 0.0 ? 1.0 : -1.0;
  return side * Eigen::Vector2d(-std::sin(s.frame.theta), std::cos(s.frame.theta));
}

double WallFollower::CostToUnexplored(const std::vector<MapSegment>& segments,
                                      const MapSegment& start, double from, int direction,
                                      const Eigen::Vector2d& away) const {
  double cost = std::abs((direction > 0 ? start.right : start.left) - from);
  const MapSegment* at = &start;
  int dir = direction;
  for (int hop = 0; hop < kMaxHops; ++hop) {
    if (EndType(*at, dir) == EndpointType::kVirtual) return cost;
    int next_direction = 0;
    const MapSegment* next = Adjacent(segments, *at, dir, away, &next_direction);
    if (next == nullptr) return cost;  // a wall end with nothing next to it: an opening
    if (next->id == start.id) break;   // went all the way round: nothing unexplored this way
    cost += next->right - next->left;
    at = next;
    dir = next_direction;
  }
  return std::numeric_limits<double>::infinity();
}

bool WallFollower::SelectSegment(const ExplorationView& view) {
  const MapSegment* best = nullptr;
  double best_distance = std::numeric_limits<double>::infinity();
  bool best_spans = false;
  for (const MapSegment& s : view.segments) {
    const Pose2 local = Relative(s.frame, view.robot);
    const bool spans = local.x >= s.left && local.x <= s.right;
    const double along = std::clamp(local.x, s.left, s.right);
    const double distance = std::hypot(local.x - along, local.y);
    // Prefer segments whose span contains the robot's projection (step 1), then the nearest.
    if ((spans && !best_spans) || (spans == best_spans && distance < best_distance)) {
      best = &s;
      best_distance = distance;
      best_spans = spans;
    }
  }
  if (best == nullptr) return false;
  tracked_ = best->id;
  const double from = Relative(best->frame, view.robot).x;
  const Eigen::Vector2d away = AwayFromWall(*best, view.robot);
  direction_ = CostToUnexplored(view.segments, *best, from, -1, away) <
                       CostToUnexplored(view.segments, *best, from, 1, away)
                   ? -1
                   : 1;
  return true;
}

std::optional<Control> WallFollower::Choose(const ExplorationView& view,
                                            const std::vector<Control>& feasible) {
  if (view.segments.empty()) return std::nullopt;
  const MapSegment* current = Find(view.segments, tracked_);
  if (current != nullptr) {
    const Pose2 local = Relative(current->frame, view.robot);
    const double along = std::clamp(local.x, current->left, current->right);
    if (std::hypot(local.x - along, local.y) > kMaxTrackDistance) current = nullptr;
  }
  if (current == nullptr && !SelectSegment(view)) return std::nullopt;
  // Step 2: near the end in the direction of travel, move on to the adjacent segment.
  for (int hop = 0; hop < kMaxHops && !rounding_; ++hop) {
    const MapSegment& s = *Find(view.segments, tracked_);
    const double along = Relative(s.frame, view.robot).x;
    const double to_end = direction_ > 0 ? s.right - along : along - s.left;
    if (to_end > options_.switch_distance) break;
    const Eigen::Vector2d away = AwayFromWall(s, view.robot);
    const Eigen::Vector2d u =
        direction_ * Eigen::Vector2d(std::cos(s.frame.theta), std::sin(s.frame.theta));
    const Pose2 end_pose = Compose(s.frame, Pose2{direction_ > 0 ? s.right : s.left, 0, 0});
    const Eigen::Vector2d end(end_pose.x, end_pose.y);
    int next_direction = 0;
    const MapSegment* next = Adjacent(view.segments, s, direction_, away, &next_direction);
    if (next == nullptr) {
      // A wall end with nothing next to it: an opening (a doorway, a free-standing wall). A real
      // end is rounded to the wall's other side and followed back there; past a virtual end the
      // wall is unknown, so keep to the line and let the map grow.
      if ((direction_ > 0 ? s.right_type : s.left_type) == EndpointType::kReal) {
        StartRounding(end, u, away, M_PI, s.id, -direction_);
      }
      break;
    }
    // An outside corner (the next wall turns away from the robot's side): round the corner onto
    // the next wall's outer face. An inside corner or a T junction: switch at once.
    const Eigen::Vector2d v =
        next_direction * Eigen::Vector2d(std::cos(next->frame.theta), std::sin(next->frame.theta));
    if (v.dot(away) < -kMinJunctionSine) {
      Eigen::Vector2d outer(-v.y(), v.x());
      if (outer.dot(u) < 0.0) outer = -outer;
      StartRounding(end, u, away, std::atan2(outer.dot(u), outer.dot(away)), next->id,
                    next_direction);
      break;
    }
    tracked_ = next->id;
    direction_ = next_direction;
  }
  // A robot that has not got anywhere for a while turns round along its wall.
  recent_.push_back(Eigen::Vector2d(view.robot.x, view.robot.y));
  if (static_cast<int>(recent_.size()) > kStuckDecisions) recent_.pop_front();
  if (static_cast<int>(recent_.size()) == kStuckDecisions &&
      (recent_.back() - recent_.front()).norm() < kStuckDistance) {
    direction_ = -direction_;
    turning_ = 0;
    rounding_ = false;
    recent_.clear();
  }
  if (rounding_) {
    std::optional<Control> control = Round(view, feasible);
    if (control) return control;
  }
  // Step 3, and on to the wall ahead when the tracking line runs into it (an inner corner).
  for (int attempt = 0; attempt < 2; ++attempt) {
    const MapSegment& s = *Find(view.segments, tracked_);
    std::optional<Control> control = Steer(view, s, feasible);
    if (control) {
      turning_ = 0;
      return control;
    }
    const MapSegment* ahead = BlockingSegment(view, s);
    if (ahead == nullptr) break;
    // Follow the blocking wall away from the one it meets, keeping the robot on the same side.
    const Eigen::Vector2d away = AwayFromWall(s, view.robot);
    const Eigen::Vector2d along(std::cos(ahead->frame.theta), std::sin(ahead->frame.theta));
    tracked_ = ahead->id;
    direction_ = along.dot(away) >= 0.0 ? 1 : -1;
  }
  // Nothing moves the robot along its line: rotate in place away from the wall, and keep rotating
  // the same way until a forward move helps (rotating back and forth would never get anywhere).
  if (turning_ == 0) {
    const MapSegment& s = *Find(view.segments, tracked_);
    const double side = Relative(s.frame, view.robot).y >= 0.0 ? 1.0 : -1.0;
    turning_ = side * direction_ > 0 ? 1 : -1;
  }
  return Control{0.0, turning_ * options_.max_angular};
}

std::optional<Control> WallFollower::Steer(const ExplorationView& view, const MapSegment& s,
                                           const std::vector<Control>& feasible) const {
  const Pose2 local = Relative(s.frame, view.robot);
  const double side = local.y >= 0.0 ? 1.0 : -1.0;
  const Pose2 target = Compose(
      s.frame, Pose2{local.x + direction_ * options_.lookahead, side * options_.wall_offset,
                     direction_ > 0 ? 0.0 : M_PI});
  return SteerTo(view, target, feasible);
}

std::optional<Control> WallFollower::SteerTo(const ExplorationView& view, const Pose2& target,
                                             const std::vector<Control>& feasible) const {
  const auto cost = [&](const Pose2& pose) {
    return std::hypot(pose.x - target.x, pose.y - target.y) +
           kHeadingWeight * std::abs(NormalizeAngle(pose.theta - target.theta));
  };
  const double standing = cost(view.robot);
  std::optional<Control> best;
  double best_cost = standing;
  bool forward_helps = false;
  for (const Control& c : feasible) {
    const Pose2 end =
        Compose(view.robot, UnicycleArc(c.linear, c.angular, options_.observation_period));
    const double k = cost(end);
    if (c.linear > 0.0 && k < standing - kMinProgress) forward_helps = true;
    if (k < best_cost) {
      best_cost = k;
      best = c;
    }
  }
  // Turning in place towards the target is progress only if driving will follow: facing a wall,
  // aligning and back again would go on for ever.
  const double heading_error = std::abs(NormalizeAngle(view.robot.theta - target.theta));
  if (!forward_helps && heading_error < kAligned) return std::nullopt;
  return best;
}

void WallFollower::StartRounding(const Eigen::Vector2d& end, const Eigen::Vector2d& u,
                                 const Eigen::Vector2d& n, double until, std::uint64_t then_track,
                                 int then_direction) {
  rounding_ = true;
  round_end_ = end;
  round_u_ = u;
  round_n_ = n;
  round_until_ = until;
  round_next_ = then_track;
  round_next_direction_ = then_direction;
}

std::optional<Control> WallFollower::Round(const ExplorationView& view,
                                           const std::vector<Control>& feasible) {
  // The robot's angle around the corner or end, from the side it came on (0) past the end
  // (pi/2) to the wall's other side (pi), on a circle of radius wall_offset.
  const Eigen::Vector2d p = Eigen::Vector2d(view.robot.x, view.robot.y) - round_end_;
  const double r = options_.wall_offset;
  const double phi = std::atan2(p.dot(round_u_), p.dot(round_n_));
  if (p.norm() > kMaxTrackDistance || phi > round_until_ - kAligned) {
    // Round (or given up): follow the next wall (or the same one back on its other side).
    rounding_ = false;
    if (Find(view.segments, round_next_) != nullptr) {
      tracked_ = round_next_;
      direction_ = round_next_direction_;
    }
    return std::nullopt;
  }
  const double target_phi = std::min(std::max(phi, 0.0) + options_.lookahead / r, round_until_);
  const Eigen::Vector2d point =
      round_end_ + r * (std::cos(target_phi) * round_n_ + std::sin(target_phi) * round_u_);
  const Eigen::Vector2d tangent = -std::sin(target_phi) * round_n_ + std::cos(target_phi) * round_u_;
  std::optional<Control> control =
      SteerTo(view, Pose2{point.x(), point.y(), std::atan2(tangent.y(), tangent.x())}, feasible);
  if (control) turning_ = 0;
  return control;
}

const MapSegment* WallFollower::BlockingSegment(const ExplorationView& view,
                                                const MapSegment& tracked) const {
  const Eigen::Vector2d origin(view.robot.x, view.robot.y);
  const Eigen::Vector2d ray = direction_ * Eigen::Vector2d(std::cos(tracked.frame.theta),
                                                           std::sin(tracked.frame.theta));
  const double reach = options_.wall_offset + options_.lookahead + options_.robot_radius;
  const MapSegment* best = nullptr;
  double best_t = reach;
  for (const MapSegment& other : view.segments) {
    if (other.id == tracked.id) continue;
    const Pose2 a = Compose(other.frame, Pose2{other.left, 0, 0});
    const Pose2 b = Compose(other.frame, Pose2{other.right, 0, 0});
    const Eigen::Vector2d pa(a.x, a.y), ab(b.x - a.x, b.y - a.y);
    const double denom = ray.x() * ab.y() - ray.y() * ab.x();
    if (std::abs(denom) < 1e-9) continue;
    const Eigen::Vector2d ao = pa - origin;
    const double t = (ao.x() * ab.y() - ao.y() * ab.x()) / denom;
    const double u = (ao.x() * ray.y() - ao.y() * ray.x()) / denom;
    if (t > 0.0 && t < best_t && u >= -0.05 && u <= 1.05) {
      best_t = t;
      best = &other;
    }
  }
  return best;
}

}  // namespace waymark::laser_slam
