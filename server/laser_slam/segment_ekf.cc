#include "server/laser_slam/segment_ekf.h"
#include "server/laser_slam/segment_ekf_internal.h"

// The filter: prediction, association, update, centering and new segments. The map's upkeep
// (freezing, pruning, merging) is in segment_ekf_upkeep.cc.

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include <Eigen/Cholesky>

#include "server/common/stopwatch.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/sp_jacobians.h"

namespace waymark::laser_slam {
namespace {

// An observation passing a REAL map endpoint by more than this means the endpoint was not one.
constexpr double kRealEndpointSlack = 0.3;  // m
// Centering transforms the covariance by Q = J2{+}^-1 of the correction, which differs from the
// identity by the order of the correction. Far from the robot an update moves a segment by
// micrometres; transforming its rows and columns then changes the covariance by a relative 1e-5
// while costing O(n) each - most of the update time on a large map. Below this correction
// (m or rad) only the estimate moves (ours).
constexpr double kCenteringSkip = 1e-5;
// The segment frame is moved back to the segment's midpoint only when it has drifted this far
// from it (m): any frame on the line is exact; the midpoint only keeps the angle's moment arm short.
constexpr double kRecentreDistance = 0.25;

double Sq(double v) { return v * v; }

// Copies the strictly lower triangle of the square block onto the upper one (from_lower) or the
// upper onto the lower, in square tiles: the plain element loop reads or writes one element per
// cache line across the whole matrix (4 MB at 700 states).
void MirrorTriangle(Eigen::Block<Eigen::MatrixXd> c, bool from_lower) {
  constexpr int kTile = 16;
  const int n = static_cast<int>(c.rows());
  const std::ptrdiff_t stride = c.outerStride();
  double* data = c.data();
  for (int bj = 0; bj < n; bj += kTile) {
    const int j_end = std::min(n, bj + kTile);
    for (int bi = bj; bi < n; bi += kTile) {
      const int i_end = std::min(n, bi + kTile);
      if (from_lower) {
        // Column i of the upper tile, rows j: written down the column, read along row i.
        for (int i = bi; i < i_end; ++i) {
          double* out = data + i * stride;
          const double* in = data + i;
          const int last = std::min(j_end, i);
          for (int j = bj; j < last; ++j) out[j] = in[j * stride];
        }
      } else {
        for (int j = bj; j < j_end; ++j) {
          double* out = data + j * stride;
          const double* in = data + j;
          for (int i = std::max(bi, j + 1); i < i_end; ++i) out[i] = in[i * stride];
        }
      }
    }
  }
}

}  // namespace

SegmentEkf::SegmentEkf(const EkfOptions& options) : options_(options) {}

void SegmentEkf::Predict(const Pose2& u, const Eigen::Matrix3d& noise) {
  const Eigen::Matrix3d f = PredictionJacobian(u);
  state_.robot = Compose(state_.robot, u);
  const int n = state_.size();
  auto c = state_.cov();
  // Robot rows and columns: C_RR' = F C_RR F^T + Q, C_RF' = F C_RF.
  const Eigen::Matrix3d rr = f * c.topLeftCorner<3, 3>() * f.transpose() + noise;
  if (n > 3) {
    Eigen::MatrixXd rf = f * c.topRightCorner(3, n - 3);
    c.topRightCorner(3, n - 3) = rf;
    c.bottomLeftCorner(n - 3, 3) = rf.transpose();
  }
  c.topLeftCorner<3, 3>() = 0.5 * (rr + rr.transpose());
}

std::vector<int> SegmentEkf::NearbySegments(double radius) const {
  std::vector<int> nearby;
  const Eigen::Vector2d robot(state_.robot.x, state_.robot.y);
  for (int i = 0; i < static_cast<int>(state_.segments.size()); ++i) {
    const SegmentEntity& s = state_.segments[i];
    // Distance from the robot to the segment (closest point).
    const Pose2 local = Relative(s.frame, Pose2{robot.x(), robot.y(), 0.0});
    const double along = std::clamp(local.x, s.left, s.right);
    if (std::hypot(local.x - along, local.y) <= radius) nearby.push_back(i);
  }
  return nearby;
}

bool SegmentEkf::Associate(const ObservedSegment& observed, const Pose2& laser_pose,
                           const std::vector<int>& candidates, Match* best) const {
  const ObservedSegment flipped = Flipped(observed);
  const Pose2 world = Compose(state_.robot, Compose(laser_pose, observed.frame));
  bool found = false;
  auto c = state_.cov();
  for (int index : candidates) {
    const SegmentEntity& s = state_.segments[index];
    const bool flip = std::abs(NormalizeAngle(world.theta - s.frame.theta)) > M_PI / 2;
    const ObservedSegment& obs = flip ? flipped : observed;
    const Pose2 in_robot = Compose(laser_pose, obs.frame);
    const Pose2 z0 = Relative(s.frame, Compose(state_.robot, in_robot));
    if (std::abs(z0.theta) > kMaxMatchAngle || std::abs(z0.y) > kMaxMatchOffset) continue;
    // Overlap along the map line, allowing a gap of overlap_margin.
    const double ct = std::cos(z0.theta);
    const double lo = z0.x + obs.left * ct, hi = z0.x + obs.right * ct;
    if (hi < s.left - options_.overlap_margin || lo > s.right + options_.overlap_margin) continue;

    const RelativeLine rel = RelateLines(s.frame, state_.robot, in_robot);
    // Innovation covariance of f = (z_y, z_theta) over [robot(3), line(2)] and the observation.
    Eigen::Matrix<double, 2, 5> h;
    h.leftCols<3>() = rel.d_b.bottomRows<2>();
    h.rightCols<2>() = rel.d_a.bottomRows<2>();
    const std::array<int, 5> dofs = {0, 1, 2, s.dof[0], s.dof[1]};
    Eigen::Matrix<double, 5, 5> p;
    for (int r = 0; r < 5; ++r) {
      for (int q = 0; q < 5; ++q) p(r, q) = c(dofs[r], dofs[q]);
    }
    const Eigen::Matrix<double, 2, 2> g = rel.d_c.bottomRows<2>();
    const Eigen::Matrix2d innovation_cov =
        h * p * h.transpose() + g * obs.line_covariance * g.transpose();
    const Eigen::Vector2d f = rel.z.tail<2>();
    const double d = f.dot(innovation_cov.ldlt().solve(f));
    if (!std::isfinite(d) || d > options_.match_chi2) continue;
    if (!found || d < best->distance) {
      found = true;
      best->segment = index;
      best->obs = obs;
      best->in_robot = in_robot;
      best->rel = rel;
      best->distance = d;
    }
  }
  return found;
}

void SegmentEkf::AppendRows(const Match& m, std::vector<Row>* rows) const {
  const SegmentEntity& s = state_.segments[m.segment];
  const RelativeLine& rel = m.rel;
  const int block = rows->empty() ? 0 : rows->back().match_block + 1;
  // Line rows: z_y = 0 and z_theta = 0.
  for (int r = 1; r <= 2; ++r) {
    Row row;
    row.match_block = block;
    row.innovation = -rel.z(r);
    for (int k = 0; k < 3; ++k) row.Add(k, rel.d_b(r, k));
    row.Add(s.dof[0], rel.d_a(r, 0));
    row.Add(s.dof[1], rel.d_a(r, 1));
    row.noise_jacobian(0) = rel.d_c(r, 0);
    row.noise_jacobian(1) = rel.d_c(r, 1);
    rows->push_back(row);
  }
  // Endpoint rows where both the map and the observation see a real endpoint:
  // f_e = z_x + b_e cos z_theta - (a_e + p_e) = 0.
  const double st = std::sin(rel.z(2)), ct = std::cos(rel.z(2));
  const struct {
    EndpointType map_type, obs_type;
    double map_abscissa, obs_abscissa, obs_variance;
    int dof, noise_slot;
  } sides[2] = {{s.left_type, m.obs.left_type, s.left, m.obs.left, m.obs.left_variance, s.dof[2], 2},
                {s.right_type, m.obs.right_type, s.right, m.obs.right, m.obs.right_variance,
                 s.dof[3], 3}};
  for (const auto& side : sides) {
    if (side.map_type != EndpointType::kReal || side.obs_type != EndpointType::kReal) continue;
    Row row;
    row.match_block = block;
    const double predicted = rel.z(0) + side.obs_abscissa * ct;
    row.innovation = -(predicted - side.map_abscissa);
    const Eigen::RowVector3d drow_b = rel.d_b.row(0) - side.obs_abscissa * st * rel.d_b.row(2);
    const Eigen::RowVector2d drow_a = rel.d_a.row(0) - side.obs_abscissa * st * rel.d_a.row(2);
    const Eigen::RowVector2d drow_c = rel.d_c.row(0) - side.obs_abscissa * st * rel.d_c.row(2);
    for (int k = 0; k < 3; ++k) row.Add(k, drow_b(k));
    row.Add(s.dof[0], drow_a(0));
    row.Add(s.dof[1], drow_a(1));
    row.Add(side.dof, -1.0);
    row.noise_jacobian(0) = drow_c(0);
    row.noise_jacobian(1) = drow_c(1);
    row.noise_jacobian(side.noise_slot) = ct;
    // Individual gate on the endpoint: a wrong real endpoint must not drag the line along.
    double var = Sq(ct) * side.obs_variance + drow_c * m.obs.line_covariance * drow_c.transpose();
    for (int i = 0; i < row.count; ++i) {
      for (int j = 0; j < row.count; ++j) {
        var += row.value[i] * state_.at(row.dof[i], row.dof[j]) * row.value[j];
      }
    }
    if (Sq(row.innovation) / var > options_.endpoint_chi2) continue;
    rows->push_back(row);
  }
}

bool SegmentEkf::Update(const std::vector<Row>& rows, const Eigen::MatrixXd& noise) {
  const int m = static_cast<int>(rows.size());
  const int n = state_.size();
  if (m == 0) return true;
  auto c = state_.cov();
  // P H^T using the sparsity of H: each row touches at most six dofs.
  Eigen::MatrixXd pht = Eigen::MatrixXd::Zero(n, m);
  for (int r = 0; r < m; ++r) {
    for (int k = 0; k < rows[r].count; ++k) pht.col(r) += c.col(rows[r].dof[k]) * rows[r].value[k];
  }
  Eigen::MatrixXd s = noise;
  for (int r = 0; r < m; ++r) {
    for (int k = 0; k < rows[r].count; ++k) s.row(r) += rows[r].value[k] * pht.row(rows[r].dof[k]);
  }
  s = 0.5 * (s + s.transpose()).eval();
  Eigen::LLT<Eigen::MatrixXd> llt(s);
  if (llt.info() != Eigen::Success) return false;
  Eigen::VectorXd nu(m);
  for (int r = 0; r < m; ++r) nu(r) = rows[r].innovation;
  const Eigen::VectorXd correction = pht * llt.solve(nu);
  // C -= (P H^T) S^-1 (P H^T)^T as a symmetric rank-m downdate with U = P H^T L^-T: half the
  // flops of the plain product; the upper triangle is mirrored afterwards.
  const Eigen::MatrixXd u = llt.matrixL().solve(pht.transpose()).transpose();
  c.selfadjointView<Eigen::Lower>().rankUpdate(u, -1.0);
  MirrorLower();
  Center(correction);
  return true;
}

void SegmentEkf::ApplyToCovariance(const std::vector<int>& dofs, const Eigen::MatrixXd& q) {
  auto c = state_.cov();
  const int k = static_cast<int>(dofs.size());
  const int n = state_.size();
  Eigen::MatrixXd rows(k, n);
  for (int i = 0; i < k; ++i) rows.row(i) = c.row(dofs[i]);
  rows = (q * rows).eval();
  for (int i = 0; i < k; ++i) c.row(dofs[i]) = rows.row(i);
  Eigen::MatrixXd cols(n, k);
  for (int i = 0; i < k; ++i) cols.col(i) = c.col(dofs[i]);
  cols = (cols * q.transpose()).eval();
  for (int i = 0; i < k; ++i) c.col(dofs[i]) = cols.col(i);
  MirrorLower();
}

void SegmentEkf::TransformColumns(const std::vector<Transform>& transforms) {
  auto c = state_.cov();
  const int n = state_.size();
  Eigen::Matrix<double, Eigen::Dynamic, 3> cols(n, 3);
  for (const Transform& t : transforms) {
    const int k = t.size;
    for (int i = 0; i < k; ++i) cols.col(i) = c.col(t.dofs[i]);
    for (int i = 0; i < k; ++i) {
      c.col(t.dofs[i]) = cols.leftCols(k) * t.q.row(i).head(k).transpose();
    }
  }
}

void SegmentEkf::ApplyTransforms(const std::vector<Transform>& transforms) {
  if (transforms.empty()) return;
  // C' = Q C Q^T for a block-diagonal Q, as two passes over contiguous columns: C1 = C Q^T, then
  // the upper triangle of Q C1 column by column (a transform's rows within each column), and the
  // lower triangle as its mirror. Row-wise updates of a column-major matrix would touch one cache
  // line per element.
  TransformColumns(transforms);
  TransformRowsOfUpper(transforms);
  MirrorTriangle(state_.cov(), /*from_lower=*/false);
}

void SegmentEkf::TransformRowsOfUpper(const std::vector<Transform>& transforms) {
  // D = Q C1, column by column (each column's few transformed rows lie in that column's own
  // memory), for the upper triangle only: the lower one is D's mirror. The sum runs in the order
  // the transposed pass it replaces ran it (Eigen's coefficient-wise product), so the covariance
  // is the same to the bit: a transpose of the whole matrix in place was 8 % of MIT CSAIL's time.
  auto c = state_.cov();
  const int n = state_.size();
  for (int j = 0; j < n; ++j) {
    double* col = &c.coeffRef(0, j);
    for (const Transform& t : transforms) {
      const int k = t.size;
      // Rows above the diagonal only (row <= j); a transform's rows straddling it are all done.
      // A transform's dofs ascend (the robot's 0, 1, 2; a segment's two consecutive ones).
      if (t.dofs[0] > j) continue;
      double x[3];
      for (int m = 0; m < k; ++m) x[m] = col[t.dofs[m]];
      for (int i = 0; i < k; ++i) {
        double sum = x[0] * t.q(i, 0);
        for (int m = 1; m < k; ++m) sum += x[m] * t.q(i, m);
        col[t.dofs[i]] = sum;
      }
    }
  }
}

void SegmentEkf::CopyForRollback(SegmentEkf* backup) const {
  backup->options_ = options_;
  backup->state_.AssignLowerTriangle(state_);
  backup->next_id_ = next_id_;
}

void SegmentEkf::RestoreFrom(const SegmentEkf& backup) {
  options_ = backup.options_;
  state_.AssignLowerTriangle(backup.state_);
  next_id_ = backup.next_id_;
  MirrorLower();
}

void SegmentEkf::MirrorLower() {
  // The two passes (and ApplyToCovariance's rows-then-columns) round (i, j) and (j, i)
  // differently, by about 1e-16 relative. Kept exactly symmetric (this, Update's mirror and
  // AddSegment's averaged block), the covariance is all its lower triangle, which is what a
  // checkpoint stores: a resumed session then goes on bit for bit as the uninterrupted one.
  // Without this they drifted apart by 4e-13 m over the Intel log; without AddSegment's, by 1e-19
  // in the covariance, which with loop closure changed the matches the graph accepted
  // (trajectories 0.06 m apart). Mirroring the whole matrix after every scan cost 17 % of the
  // filter's time on ACES.
  MirrorTriangle(state_.cov(), /*from_lower=*/true);
}

void SegmentEkf::Center(const Eigen::VectorXd& correction) {
  std::vector<Transform> transforms;
  const Eigen::Vector3d dr = correction.head<3>();
  state_.robot = ToPose(Eigen::Vector3d(Compose<double>(ToVector(state_.robot), dr)));
  Transform robot;
  robot.size = 3;
  robot.dofs = {0, 1, 2};
  robot.q = RobotCenteringJacobian(dr);
  transforms.push_back(robot);
  for (SegmentEntity& s : state_.segments) {
    const Eigen::Vector2d dl(correction(s.dof[0]), correction(s.dof[1]));
    const double dleft = s.dof[2] >= 0 ? correction(s.dof[2]) : 0.0;
    const double dright = s.dof[3] >= 0 ? correction(s.dof[3]) : 0.0;
    if (dl.squaredNorm() == 0.0 && dleft == 0.0 && dright == 0.0) continue;
    s.frame = Compose(s.frame, Pose2{0.0, dl(0), dl(1)});
    s.left += dleft;
    s.right += dright;
    Eigen::Matrix2d q = Eigen::Matrix2d::Identity();
    if (dl.cwiseAbs().maxCoeff() > kCenteringSkip) q = LineCenteringJacobian(dl);
    const double shift = MidpointShift(s);
    if (shift != 0.0) q = LineShiftJacobian(shift) * q;
    if (q == Eigen::Matrix2d::Identity()) continue;
    Transform t;
    t.size = 2;
    t.dofs = {s.dof[0], s.dof[1], -1};
    t.q.setIdentity();
    t.q.topLeftCorner<2, 2>() = q;
    transforms.push_back(t);
  }
  ApplyTransforms(transforms);
}

double SegmentEkf::MidpointShift(SegmentEntity& s) {
  if (s.left > s.right) std::swap(s.left, s.right);  // a collapsed segment: keep order sane
  const double shift = 0.5 * (s.left + s.right);
  if (std::abs(shift) < kRecentreDistance) return 0.0;
  s.frame = Compose(s.frame, Pose2{shift, 0.0, 0.0});
  s.left -= shift;
  s.right -= shift;
  return shift;
}

void SegmentEkf::Recentre(SegmentEntity& s) {
  const double shift = MidpointShift(s);
  if (shift != 0.0) ApplyToCovariance({s.dof[0], s.dof[1]}, LineShiftJacobian(shift));
}

bool SegmentEkf::AdjustEndpoints(const Match& m) {
  SegmentEntity& s = state_.segments[m.segment];
  // Relinearise at the updated estimates.
  const RelativeLine rel = RelateLines(s.frame, state_.robot, m.in_robot);
  const double ct = std::cos(rel.z(2)), st = std::sin(rel.z(2));
  bool changed = false;
  for (int side = 0; side < 2; ++side) {
    const bool left = side == 0;
    const double sign = left ? -1.0 : 1.0;  // outward direction along the line
    double& map_end = left ? s.left : s.right;
    EndpointType& map_type = left ? s.left_type : s.right_type;
    int& dof = s.dof[left ? 2 : 3];
    const double obs_b = left ? m.obs.left : m.obs.right;
    const EndpointType obs_type = left ? m.obs.left_type : m.obs.right_type;
    const double obs_var = left ? m.obs.left_variance : m.obs.right_variance;
    const double x = rel.z(0) + obs_b * ct;  // observed endpoint on the map line
    const double beyond = sign * (x - map_end);  // > 0: the observation reaches past the map end
    if (map_type == EndpointType::kVirtual) {
      if (obs_type == EndpointType::kReal && beyond > -kRealEndpointSlack) {
        // Insert the endpoint's degree of freedom: p_e = x(d_R, p_line, c, q_e) - x_hat.
        const int n = state_.size();
        const Eigen::RowVector3d jb = rel.d_b.row(0) - obs_b * st * rel.d_b.row(2);
        const Eigen::RowVector2d ja = rel.d_a.row(0) - obs_b * st * rel.d_a.row(2);
        const Eigen::RowVector2d jc = rel.d_c.row(0) - obs_b * st * rel.d_c.row(2);
        const std::array<int, 5> src = {0, 1, 2, s.dof[0], s.dof[1]};
        const std::array<double, 5> jac = {jb(0), jb(1), jb(2), ja(0), ja(1)};
        const int e = state_.AddDofs(1);
        auto c = state_.cov();
        Eigen::VectorXd cross = Eigen::VectorXd::Zero(n);
        for (int k = 0; k < 5; ++k) cross += jac[k] * c.col(src[k]).head(n);
        double var = Sq(ct) * obs_var + jc * m.obs.line_covariance * jc.transpose();
        for (int k = 0; k < 5; ++k) var += jac[k] * cross(src[k]);
        c.col(e).head(n) = cross;
        c.row(e).head(n) = cross.transpose();
        c(e, e) = var;
        dof = e;
        map_type = EndpointType::kReal;
        map_end = x;
        changed = true;
      } else if (beyond > 0.0) {
        map_end = x;  // extend past the virtual endpoint
        changed = true;
      }
    } else if (beyond > kRealEndpointSlack + 3.0 * std::sqrt(std::max(0.0, state_.at(dof, dof)))) {
      // The wall goes on past what we took for its end: the endpoint becomes virtual.
      const int d = dof;
      dof = -1;
      state_.RemoveDofs({d});
      map_type = EndpointType::kVirtual;
      map_end = x;
      changed = true;
    }
  }
  if (changed) Recentre(s);
  return changed;
}

void SegmentEkf::AddSegment(const ObservedSegment& obs, const Pose2& laser_pose,
                            std::uint64_t scan_index) {
  const Pose2 in_robot = Compose(laser_pose, obs.frame);
  SegmentEntity s;
  s.id = next_id_++;
  s.frame = Compose(state_.robot, in_robot);
  s.left = obs.left;
  s.right = obs.right;
  s.left_type = obs.left_type;
  s.right_type = obs.right_type;
  s.observations = 1;
  s.first_seen_scan = scan_index;
  s.last_seen_scan = scan_index;
  // New perturbation as a function of the robot's and the observation's: line (z_y, z_theta),
  // endpoints z_x + b_e (at z = 0).
  const RelativeLine rel = RelateLines(s.frame, state_.robot, in_robot);
  std::vector<Eigen::RowVector3d> jb = {rel.d_b.row(1), rel.d_b.row(2)};
  std::vector<Eigen::RowVector4d> jn = {
      Eigen::RowVector4d(rel.d_c(1, 0), rel.d_c(1, 1), 0, 0),
      Eigen::RowVector4d(rel.d_c(2, 0), rel.d_c(2, 1), 0, 0)};
  if (s.left_type == EndpointType::kReal) {
    jb.push_back(rel.d_b.row(0));
    jn.push_back(Eigen::RowVector4d(rel.d_c(0, 0), rel.d_c(0, 1), 1, 0));
  }
  if (s.right_type == EndpointType::kReal) {
    jb.push_back(rel.d_b.row(0));
    jn.push_back(Eigen::RowVector4d(rel.d_c(0, 0), rel.d_c(0, 1), 0, 1));
  }
  const int k = static_cast<int>(jb.size());
  Eigen::MatrixXd gb(k, 3), gn(k, 4);
  for (int i = 0; i < k; ++i) {
    gb.row(i) = jb[i];
    gn.row(i) = jn[i];
  }
  Eigen::Matrix4d obs_cov = Eigen::Matrix4d::Zero();
  obs_cov.topLeftCorner<2, 2>() = obs.line_covariance;
  obs_cov(2, 2) = obs.left_variance;
  obs_cov(3, 3) = obs.right_variance;
  const int n = state_.size();
  const int first = state_.AddDofs(k);
  auto c = state_.cov();
  const Eigen::MatrixXd cross = gb * c.topRows(3).leftCols(n);  // k x n
  c.block(first, 0, k, n) = cross;
  c.block(0, first, n, k) = cross.transpose();
  // G C G^T rounds (i, j) and (j, i) apart; averaged, the block is exactly symmetric (see
  // MirrorLower: the checkpoint keeps the lower triangle).
  const Eigen::MatrixXd own =
      gb * c.topLeftCorner<3, 3>() * gb.transpose() + gn * obs_cov * gn.transpose();
  c.block(first, first, k, k) = 0.5 * (own + own.transpose());
  s.dof[0] = first;
  s.dof[1] = first + 1;
  int next = first + 2;
  if (s.left_type == EndpointType::kReal) s.dof[2] = next++;
  if (s.right_type == EndpointType::kReal) s.dof[3] = next++;
  state_.segments.push_back(s);
}

ObserveStats SegmentEkf::Observe(const std::vector<ObservedSegment>& observed_in,
                                 const Pose2& laser_pose, std::uint64_t scan_index) {
  ObserveStats stats;
  const auto t0 = Clock::now();
  // Model error on top of the fit covariance (options.h, line_offset_floor and friends).
  std::vector<ObservedSegment> inflated = observed_in;
  for (ObservedSegment& o : inflated) {
    o.line_covariance(0, 0) += Sq(options_.line_offset_floor);
    o.line_covariance(1, 1) += Sq(options_.line_angle_floor);
    o.left_variance += Sq(options_.endpoint_floor);
    o.right_variance += Sq(options_.endpoint_floor);
  }
  const std::vector<ObservedSegment>& observed = inflated;
  const std::vector<int> candidates = NearbySegments(options_.association_radius);
  std::vector<Match> matches;
  std::vector<const ObservedSegment*> unmatched;
  for (const ObservedSegment& obs : observed) {
    Match match;
    if (Associate(obs, laser_pose, candidates, &match)) {
      matches.push_back(std::move(match));
    } else {
      unmatched.push_back(&obs);
    }
  }
  stats.association_ms = MsSince(t0);
  const auto t1 = Clock::now();

  std::vector<Row> rows;
  for (const Match& m : matches) AppendRows(m, &rows);
  if (!rows.empty()) {
    const int count = static_cast<int>(rows.size());
    Eigen::MatrixXd noise = Eigen::MatrixXd::Zero(count, count);
    // Rows of one match share its observation noise vector [c_y, c_theta, q_l, q_r].
    int start = 0;
    std::size_t mi = 0;
    while (start < count) {
      int end = start;
      while (end < count && rows[end].match_block == rows[start].match_block) ++end;
      const Match& m = matches[mi++];
      Eigen::Matrix4d obs_cov = Eigen::Matrix4d::Zero();
      obs_cov.topLeftCorner<2, 2>() = m.obs.line_covariance;
      obs_cov(2, 2) = m.obs.left_variance;
      obs_cov(3, 3) = m.obs.right_variance;
      for (int a = start; a < end; ++a) {
        for (int b = start; b < end; ++b) {
          noise(a, b) = rows[a].noise_jacobian * obs_cov * rows[b].noise_jacobian.transpose();
        }
      }
      start = end;
    }
    if (Update(rows, noise)) {
      stats.matched = static_cast<int>(matches.size());
      stats.map_changed = true;
      for (const Match& m : matches) {
        SegmentEntity& s = state_.segments[m.segment];
        ++s.observations;
        s.last_seen_scan = scan_index;
        if (AdjustEndpoints(m)) stats.map_changed = true;
      }
    } else {
      // Not positive definite: keep the prediction, treat the observations as new? No - a
      // numerically bad step adds nothing rather than duplicating walls.
      unmatched.clear();
    }
  }
  for (const ObservedSegment* obs : unmatched) {
    AddSegment(*obs, laser_pose, scan_index);
    ++stats.added;
    stats.map_changed = true;
  }
  stats.pruned = PruneTentative(scan_index);
  stats.frozen = FreezeOutsideWindow(scan_index);
  if (stats.pruned > 0 || stats.frozen > 0) stats.map_changed = true;
  stats.update_ms = MsSince(t1);
  return stats;
}

}  // namespace waymark::laser_slam
