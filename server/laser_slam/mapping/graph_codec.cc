#include "server/laser_slam/mapping/graph_codec.h"

#include <cmath>

#include "server/laser_slam/input_bounds.h"

namespace waymark::laser_slam {

void PutPose(BinaryWriter& w, const Pose2& p) {
  w.Put(p.x);
  w.Put(p.y);
  w.Put(p.theta);
}

bool GetPose(BinaryReader& r, Pose2* p) {
  return r.Get(&p->x) && r.Get(&p->y) && r.Get(&p->theta) && PlausibleMapPose(*p);
}

bool GetVariance(BinaryReader& r, Eigen::Vector3d* v) {
  for (int i = 0; i < 3; ++i) {
    if (!r.Get(&(*v)(i)) || !std::isfinite((*v)(i)) || (*v)(i) < 0.0) return false;
  }
  return true;
}

void PutConstraint(BinaryWriter& w, const GraphConstraint& c) {
  w.Put<std::uint8_t>(static_cast<std::uint8_t>(c.kind));
  w.Put<std::int32_t>(c.from);
  w.Put<std::int32_t>(c.to);
  PutPose(w, c.relative);
  for (int i = 0; i < 3; ++i) w.Put(c.sigma(i));
  w.Put<std::uint8_t>(c.enabled);
  w.Put(c.score);
}

bool GetConstraint(BinaryReader& r, int nodes, GraphConstraint* c) {
  std::uint8_t kind = 0, enabled = 0;
  if (!r.Get(&kind) || kind > 1 || !r.Get(&c->from) || !r.Get(&c->to) || c->from < 0 || c->to < 0 ||
      c->from >= nodes || c->to >= nodes || !GetPose(r, &c->relative)) {
    return false;
  }
  for (int i = 0; i < 3; ++i) {
    if (!r.Get(&c->sigma(i)) || !(c->sigma(i) > 0.0) || !std::isfinite(c->sigma(i))) return false;
  }
  if (!r.Get(&enabled) || !r.Get(&c->score)) return false;
  c->kind = static_cast<GraphConstraint::Kind>(kind);
  c->enabled = enabled != 0;
  return true;
}

void PutPoints(BinaryWriter& w, const PointCloud& points) {
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(points.size()));
  for (const Eigen::Vector2f& p : points) {
    w.Put(p.x());
    w.Put(p.y());
  }
}

bool GetPoints(BinaryReader& r, std::uint32_t max_points, PointCloud* points) {
  std::uint32_t count = 0;
  if (!r.Get(&count) || count > max_points || count > r.remaining() / (2 * sizeof(float))) {
    return false;
  }
  points->resize(count);
  for (Eigen::Vector2f& p : *points) {
    float x = 0, y = 0;
    if (!r.Get(&x) || !r.Get(&y) || !PlausibleRobotPoint(x, y)) return false;
    p = Eigen::Vector2f(x, y);
  }
  return true;
}

}  // namespace waymark::laser_slam
