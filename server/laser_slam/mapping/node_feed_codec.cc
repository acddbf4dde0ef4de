#include "server/laser_slam/mapping/node_feed_codec.h"

#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/common/binary_io.h"
#include "server/laser_slam/mapping/graph_codec.h"

namespace waymark::laser_slam {
namespace {

constexpr std::uint32_t kPosesMagic = 0x5046574d;   // "MWFP"
constexpr std::uint32_t kPointsMagic = 0x4e46574d;  // "MWFN"
constexpr std::uint32_t kVersion = 1;
// As many points as a checkpoint's node may hold.
constexpr std::uint32_t kMaxPoints = 100000;

absl::Status Corrupt(const char* what) {
  return absl::DataLossError(absl::StrCat("a shared map's node feed is corrupt: ", what));
}

}  // namespace

std::string EncodeFeedPoses(const std::vector<NodeView>& nodes,
                            const std::vector<GraphConstraint>& loops) {
  BinaryWriter w;
  w.Put(kPosesMagic);
  w.Put(kVersion);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(nodes.size()));
  for (const NodeView& node : nodes) {
    w.Put(node.scan);
    w.Put(node.stamp);
    PutPose(w, node.global);
    for (int i = 0; i < 3; ++i) w.Put(node.step_sigma(i));
  }
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(loops.size()));
  for (const GraphConstraint& loop : loops) PutConstraint(w, loop);
  return w.Take();
}

absl::StatusOr<FeedPoses> DecodeFeedPoses(absl::string_view bytes) {
  BinaryReader r(bytes);
  std::uint32_t magic = 0, version = 0, count = 0;
  if (!r.Get(&magic) || magic != kPosesMagic) return Corrupt("not a trajectory's poses");
  if (!r.Get(&version) || version != kVersion) return Corrupt("unknown version");
  // The least a stored node and a stored loop take, in bytes: counts are checked against what is
  // left before anything is allocated.
  constexpr size_t kPose = 3 * sizeof(double);
  constexpr size_t kNode = sizeof(std::uint64_t) + sizeof(double) + kPose + 3 * sizeof(double);
  constexpr size_t kLoop = 1 + 4 + 4 + kPose + 3 * sizeof(double) + 1 + sizeof(double);
  if (!r.Get(&count) || count > r.remaining() / kNode) return Corrupt("node count");
  FeedPoses out;
  out.nodes.resize(count);
  std::uint64_t previous_scan = 0;
  for (NodeView& node : out.nodes) {
    if (!r.Get(&node.scan) || node.scan <= previous_scan || !r.Get(&node.stamp) ||
        !std::isfinite(node.stamp) || !GetPose(r, &node.global) ||
        !GetVariance(r, &node.step_sigma)) {
      return Corrupt("node");
    }
    previous_scan = node.scan;
  }
  if (!r.Get(&count) || count > r.remaining() / kLoop) return Corrupt("loop count");
  out.loops.resize(count);
  for (GraphConstraint& loop : out.loops) {
    if (!GetConstraint(r, static_cast<int>(out.nodes.size()), &loop)) return Corrupt("loop");
  }
  if (!r.done()) return Corrupt("bytes after the loops");
  return out;
}

std::string EncodeFeedPoints(const PointCloud& points) {
  BinaryWriter w;
  w.Put(kPointsMagic);
  w.Put(kVersion);
  PutPoints(w, points);
  return w.Take();
}

absl::StatusOr<PointCloud> DecodeFeedPoints(absl::string_view bytes) {
  BinaryReader r(bytes);
  std::uint32_t magic = 0, version = 0;
  if (!r.Get(&magic) || magic != kPointsMagic) return Corrupt("not a node's points");
  if (!r.Get(&version) || version != kVersion) return Corrupt("unknown version");
  PointCloud points;
  if (!GetPoints(r, kMaxPoints, &points) || !r.done()) return Corrupt("node points");
  return points;
}

}  // namespace waymark::laser_slam
