#include "server/laser_slam/wall_follower.h"

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

Pose2 EndPoint(const MapSegment& s, int end) {
  return Compose(s.frame, Pose2{end < 0 ? s.left : s.right, 0.0, 0.0});
}

EndpointType EndType(const MapSegment& s, int end) { return end < 0 ? s.left_type : s.right_type; }

}  // namespace

void WallFollower::Reset() { tracked_ = 0; }

const MapSegment* WallFollower::Find(const std::vector<MapSegment>& segments,
                                     std::uint64_t id) const {
  for (const MapSegment& s : segments) {
    if (s.id == id) return &s;
  }
  return nullptr;
}

const MapSegment* WallFollower::Adjacent(const std::vector<MapSegment>& segments,
                                         const MapSegment& segment, int direction,
                                         int* neighbour_end) const {
  const Pose2 end = EndPoint(segment, direction);
  const MapSegment* best = nullptr;
  double best_gap = options_.adjacency;
  for (const MapSegment& other : segments) {
    if (other.id == segment.id) continue;
    for (int e : {-1, 1}) {
      const Pose2 p = EndPoint(other, e);
      const double gap = std::hypot(p.x - end.x, p.y - end.y);
      if (gap <= best_gap) {
        best_gap = gap;
        best = &other;
        *neighbour_end = e;
      }
    }
  }
  return best;
}

double WallFollower::CostToUnexplored(const std::vector<MapSegment>& segments,
                                      const MapSegment& start, double from, int direction) const {
  double cost = std::abs((direction > 0 ? start.right : start.left) - from);
  const MapSegment* at = &start;
  int dir = direction;
  for (int hop = 0; hop < kMaxHops; ++hop) {
    if (EndType(*at, dir) == EndpointType::kVirtual) return cost;
    int neighbour_end = 0;
    const MapSegment* next = Adjacent(segments, *at, dir, &neighbour_end);
    if (next == nullptr) return cost;  // a wall end with nothing next to it: an opening
    if (next->id == start.id) break;   // went all the way round: nothing unexplored this way
    cost += next->right - next->left;
    at = next;
    dir = -neighbour_end;  // leave the neighbour by its other end
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
  direction_ = CostToUnexplored(view.segments, *best, from, -1) <
                       CostToUnexplored(view.segments, *best, from, 1)
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
  for (int hop = 0; hop < kMaxHops; ++hop) {
    const MapSegment& s = *Find(view.segments, tracked_);
    const double along = Relative(s.frame, view.robot).x;
    const double to_end = direction_ > 0 ? s.right - along : along - s.left;
    if (to_end > options_.switch_distance) break;
    int neighbour_end = 0;
    const MapSegment* next = Adjacent(view.segments, s, direction_, &neighbour_end);
    if (next == nullptr) break;  // an opening: keep to this line and go past its end
    tracked_ = next->id;
    direction_ = -neighbour_end;
  }
  // Step 3: steer onto the tracking line.
  const MapSegment& s = *Find(view.segments, tracked_);
  const Pose2 local = Relative(s.frame, view.robot);
  const double side = local.y >= 0.0 ? 1.0 : -1.0;
  const double line_y = side * options_.wall_offset;
  const double target_x = local.x + direction_ * options_.lookahead;
  const double target_heading = direction_ > 0 ? 0.0 : M_PI;
  const auto cost = [&](const Pose2& pose_in_segment) {
    return std::hypot(pose_in_segment.x - target_x, pose_in_segment.y - line_y) +
           kHeadingWeight * std::abs(NormalizeAngle(pose_in_segment.theta - target_heading));
  };
  const double standing = cost(local);
  std::optional<Control> best;
  double best_cost = standing;
  for (const Control& c : feasible) {
    const Pose2 end = Compose(local, UnicycleArc(c.linear, c.angular, options_.observation_period));
    const double k = cost(end);
    if (k < best_cost) {
      best_cost = k;
      best = c;
    }
  }
  if (best) return best;
  // No control brings the robot closer: rotate in place towards the line's direction.
  const double turn = NormalizeAngle(target_heading - local.theta);
  return Control{0.0, turn >= 0.0 ? options_.max_angular : -options_.max_angular};
}

}  // namespace waymark::laser_slam
