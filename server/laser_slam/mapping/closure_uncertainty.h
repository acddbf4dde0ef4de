#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_CLOSURE_UNCERTAINTY_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_CLOSURE_UNCERTAINTY_H_

// How uncertain the newest node is relative to each submap, through the graph's closures as well
// as its chain: what sizes the loop search's windows (MappingOptions::window_through_ties).
//
// A closure from node n to submap A says where the robot was relative to A at n; it ties the robot
// to A, and to another submap only through what ties A to that one: the chain between them, or
// other closures. Taking the chain since the newest closure as the uncertainty to every submap
// (what the back end did before issue 33's fifth part) shrank a 16 m window to a submap 1000 scans
// back to 0.2 m on MIT Killian after a closure 15 m back, and the loop never closed; taking the
// chain alone overstates it where earlier closures already tie the two.
//
// The submaps are the vertices of a graph: consecutive submaps joined by the chain between their
// first nodes, and each closure joining its submap to the submap of the node it closed from (the
// closure's own sigma plus the chain from that submap's first node to the node). A shortest-path
// search from the robot (its own submap, by the chain since its first node) adds each edge's
// position variance and its heading variance times the squared lever arm from the edge to the
// robot, as ChainUncertainty does along a chain; the heading variances add along the path. Each
// submap's answer is the smaller of that and the chain since the submap.

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/mapping/chain_uncertainty.h"

namespace waymark::laser_slam {

struct SubmapSpan {
  int first = 0;  // node indices [first, last], in order of first
  int last = 0;
};

struct ClosureTie {
  int submap = 0;  // the submap closed on
  int node = 0;    // the node that closed on it
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();  // the closure's 1 sigma (x, y, theta)
};

// Node `index`'s uncertainty relative to each of `submaps` (one answer per submap, in order).
// Nodes must be < chain.size(); closures to nodes after `index` are ignored.
std::vector<ChainUncertainty::Sigma> UncertaintyToSubmaps(const ChainUncertainty& chain,
                                                          const std::vector<SubmapSpan>& submaps,
                                                          const std::vector<ClosureTie>& closures,
                                                          int index);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_CLOSURE_UNCERTAINTY_H_
