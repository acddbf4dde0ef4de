#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_CHAIN_UNCERTAINTY_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_CHAIN_UNCERTAINTY_H_

// How uncertain a node's pose is relative to an older node when only the chain of consecutive
// constraints ties them: what sizes the loop search's window (docs/laser-slam.md, "Loop
// closure"). Each chain step k adds its own variance (sigma_xy^2 in position, sigma_theta^2 in
// heading), and its heading error swings every later node about node k: a node b moves by
// sigma_theta,k * |p_b - p_k|. Summed over the steps between a and b (independent errors):
//   var_theta(a, b) = sum_k s_k,   s_k = sigma_theta,k^2
//   var_xy(a, b)    = sum_k sigma_xy,k^2 + sum_k s_k |p_b - p_k|^2
// The second sum expands to |p_b|^2 S - 2 p_b . P + R with prefix sums S = sum s_k,
// P = sum s_k p_k, R = sum s_k |p_k|^2, so any pair costs O(1) after O(1) per node. Positions are
// the EKF's local ones: they never move, and the chain is the EKF's (or the front end's) motion.

#include <vector>

#include <Eigen/Core>

namespace waymark::laser_slam {

class ChainUncertainty {
 public:
  // The next node: its local position and the 1 sigma (x, y, theta) of the step that reached it
  // (ignored for the first node).
  void Append(const Eigen::Vector2d& position, const Eigen::Vector3d& step_sigma);
  int size() const { return static_cast<int>(prefix_.size()); }
  void clear() { prefix_.clear(); }

  struct Sigma {
    double xy = 0.0;     // m, 1 sigma of the position (per axis, conservatively the whole)
    double theta = 0.0;  // rad
  };
  // Node b's pose relative to node a along the chain (a <= b < size()); zero for a == b.
  Sigma Between(int a, int b) const;

  // The local position of node i (0 <= i < size()).
  const Eigen::Vector2d& Position(int i) const { return prefix_[i].position; }

 private:
  struct Prefix {
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    double xy = 0.0;                                    // sum of sigma_xy^2
    double s = 0.0;                                     // sum of sigma_theta^2
    Eigen::Vector2d p = Eigen::Vector2d::Zero();        // sum of s_k p_k
    double r = 0.0;                                     // sum of s_k |p_k|^2
  };
  std::vector<Prefix> prefix_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_CHAIN_UNCERTAINTY_H_
