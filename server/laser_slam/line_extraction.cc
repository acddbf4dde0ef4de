#include "server/laser_slam/line_extraction.h"

// Line extraction per scan (METHODS.md section 2):
//  1. Beams -> points. No-returns (NaN, inf, <= 0, < min_range, >= no_return_range) and readings
//     beyond max_range are not points; both break clusters.
//  2. Clusters: maximal runs of points whose consecutive distance is at most
//     discontinuity_abs + discontinuity_rel * max(r_i, r_i+1) (the larger range, because the
//     spacing of points on an oblique wall grows with the farther one).
//  3. Iterative end-point fit (while the least-squares line of a piece leaves a point further than
//     split_distance, split it at the point farthest from the end-point chord); each split point is
//     then handed to the segment whose line it is closer to; weighted least-squares fit per segment
//     (line_fit.h); adjacent segments on one line are merged and refitted (see Agree); boundary
//     points that lie closer to the neighbour's line move there; pieces too small to be kept give
//     their points to a neighbouring line that passes through them (see AbsorbSmallPieces).
//  4. Endpoints classified (see Endpoint), segment frame and covariances computed (see Finish).
//  5. Segments with too few points, too short, or at too small an incidence are dropped.

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/LU>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/line_fit.h"

namespace waymark::laser_slam {
namespace {

enum class BeamState : std::uint8_t { kPoint, kNoReturn, kOutOfRange };

struct Seg {
  int first = 0;  // inclusive beam indices
  int last = 0;
  PolarLine line;
  int count() const { return last - first + 1; }
};

// Angle between two undirected lines given by their normal angles, in [0, pi/2].
double LineAngle(double phi_a, double phi_b) {
  const double d = std::abs(NormalizeAngle(phi_a - phi_b));
  return std::min(d, M_PI - d);
}

// Abscissa of the midpoint of the projections of a segment's first and last points.
double MidTau(const Seg& s, const std::vector<ScanPoint>& pts) {
  return 0.5 *
         (s.line.Tau(pts[s.first].x, pts[s.first].y) + s.line.Tau(pts[s.last].x, pts[s.last].y));
}

void PointOnLine(const PolarLine& l, double tau, double* x, double* y) {
  const double c = std::cos(l.phi), s = std::sin(l.phi);
  *x = l.rho * c - tau * s;
  *y = l.rho * s + tau * c;
}

// Variance of rho - tau * dphi: the line's own uncertainty at abscissa tau, across the line.
double LineVarianceAt(const PolarLine& l, double tau) {
  const Eigen::Vector2d g(1.0, -tau);
  return g.dot(l.covariance * g);
}

class Extractor {
 public:
  Extractor(const LaserScan& scan, const LineExtractionOptions& o)
      : o_(o), n_(scan.geometry.beam_count), inc_(std::abs(scan.geometry.angle_increment)) {
    pts_.resize(n_);
    state_.resize(n_);
    for (int i = 0; i < n_; ++i) {
      const double a = scan.geometry.angle_min + i * scan.geometry.angle_increment;
      const double r = scan.ranges[i];
      ScanPoint& p = pts_[i];
      p.c = std::cos(a);
      p.s = std::sin(a);
      if (!IsReturn(r, scan.geometry) || r < o.min_range) {
        state_[i] = BeamState::kNoReturn;
      } else if (r > o.max_range) {
        state_[i] = BeamState::kOutOfRange;
      } else {
        state_[i] = BeamState::kPoint;
        p.valid = true;
        p.r = r;
        p.x = r * p.c;
        p.y = r * p.s;
      }
    }
  }

  std::vector<ObservedSegment> Run() {
    std::vector<ObservedSegment> out;
    int i = 0;
    while (i < n_) {
      if (state_[i] != BeamState::kPoint) {
        ++i;
        continue;
      }
      int j = i;
      while (j + 1 < n_ && state_[j + 1] == BeamState::kPoint && Continuous(j, j + 1)) ++j;
      if (j > i) ProcessCluster(i, j, &out);
      i = j + 1;
    }
    return out;
  }

 private:
  bool Continuous(int a, int b) const {
    const double dx = pts_[a].x - pts_[b].x, dy = pts_[a].y - pts_[b].y;
    const double limit =
        o_.discontinuity_abs + o_.discontinuity_rel * std::max(pts_[a].r, pts_[b].r);
    return dx * dx + dy * dy <= limit * limit;
  }

  PolarLine Fit(int first, int last) const {
    return FitLine(pts_, first, last, o_.range_sigma, o_.bearing_sigma);
  }

  // True when the least-squares line of [a, b] keeps every point within split_distance. The split
  // decision uses it rather than the end-point chord alone: the chord runs through two noisy
  // points, so one 3-4 sigma reading would often split a straight wall. Where to split is still the
  // point farthest from the chord (at a corner that is the corner point).
  bool FitsWithin(int a, int b) const {
    const PolarLine l = Fit(a, b);
    if (!l.ok) return false;
    for (int i = a; i <= b; ++i) {
      if (std::abs(l.Distance(pts_[i].x, pts_[i].y)) > o_.split_distance) return false;
    }
    return true;
  }

  // Iterative end-point fit on [first, last]: breakpoints in order, first and last included.
  void SplitCluster(int first, int last, std::vector<int>* breaks) {
    breaks->clear();
    breaks->push_back(first);
    stack_.clear();
    stack_.emplace_back(first, last);
    while (!stack_.empty()) {
      const auto [a, b] = stack_.back();
      stack_.pop_back();
      int worst = -1;
      double worst_d = o_.split_distance;
      if (b - a >= 2 && !FitsWithin(a, b)) {
        const double dx = pts_[b].x - pts_[a].x, dy = pts_[b].y - pts_[a].y;
        const double len = std::hypot(dx, dy);
        for (int k = a + 1; k < b; ++k) {
          const double px = pts_[k].x - pts_[a].x, py = pts_[k].y - pts_[a].y;
          const double d = len > 1e-12 ? std::abs(px * dy - py * dx) / len : std::hypot(px, py);
          if (d > worst_d) {
            worst_d = d;
            worst = k;
          }
        }
      }
      if (worst < 0) {
        breaks->push_back(b);
      } else {
        stack_.emplace_back(worst, b);  // popped second
        stack_.emplace_back(a, worst);  // popped first: breakpoints come out in order
      }
    }
  }

  // Two adjacent segments are one line when
  //  - their lines agree within merge_angle and each midpoint lies within merge_distance of the
  //    other line (the geometric test of the options), or
  //  - the line fitted to both keeps every point within split_distance: the split criterion itself,
  //    so a merge never undoes a split that the union would need. This undoes the splits that the
  //    end-point chord makes in the middle of a wall (the chord of two walls can be parallel to one
  //    of them, and any noisy point of that wall is then the farthest), and short pieces whose
  //    angle is too uncertain for the geometric test.
  bool Agree(const Seg& a, const Seg& b, PolarLine* merged) const {
    double ax, ay, bx, by;
    PointOnLine(a.line, MidTau(a, pts_), &ax, &ay);
    PointOnLine(b.line, MidTau(b, pts_), &bx, &by);
    *merged = Fit(a.first, b.last);
    if (!merged->ok) return false;
    if (LineAngle(a.line.phi, b.line.phi) < o_.merge_angle &&
        std::abs(b.line.Distance(ax, ay)) < o_.merge_distance &&
        std::abs(a.line.Distance(bx, by)) < o_.merge_distance) {
      return true;
    }
    for (int i = a.first; i <= b.last; ++i) {
      if (std::abs(merged->Distance(pts_[i].x, pts_[i].y)) > o_.split_distance) return false;
    }
    return true;
  }

  // Merges adjacent segments on one line (see Agree) and refits them.
  void MergeNeighbours() {
    for (size_t k = 0; k + 1 < segs_.size();) {
      const Seg& a = segs_[k];
      const Seg& b = segs_[k + 1];
      PolarLine merged;
      if (a.line.ok && b.line.ok && a.last + 1 == b.first && Agree(a, b, &merged)) {
        Seg m;
        m.first = a.first;
        m.last = b.last;
        m.line = merged;
        segs_[k] = m;
        segs_.erase(segs_.begin() + k + 1);
        if (k > 0) --k;  // the merged line may now agree with its left neighbour
        continue;
      }
      ++k;
    }
  }

  // Pieces with fewer than min_points points (they would be dropped) give their points, from the
  // ends inwards, to an adjacent well-supported segment whose line passes within split_distance of
  // them. The end-point chord of a long piece made of two walls can be farthest from a point that
  // is not the corner (e.g. a wall parallel to the chord), and the following splits then leave a
  // few points of one wall as a piece of their own next to the corner; without this the wall would
  // end short of the corner and the corner would not be seen.
  void AbsorbSmallPieces() {
    const int small = std::max(o_.min_points, 3);
    bool changed = true;
    for (int guard = 0; changed && guard < 4 * n_; ++guard) {
      changed = false;
      for (size_t k = 0; k + 1 < segs_.size(); ++k) {
        Seg& a = segs_[k];
        Seg& b = segs_[k + 1];
        if (a.last + 1 != b.first) continue;
        if (b.count() < small && a.count() >= small && a.line.ok) {
          const ScanPoint& p = pts_[b.first];
          if (std::abs(a.line.Distance(p.x, p.y)) <= o_.split_distance) {
            ++a.last;
            ++b.first;
            changed = true;
          }
        } else if (a.count() < small && b.count() >= small && b.line.ok) {
          const ScanPoint& p = pts_[a.last];
          if (std::abs(b.line.Distance(p.x, p.y)) <= o_.split_distance) {
            --a.last;
            --b.first;
            changed = true;
          }
        }
        if (changed) {
          a.line = Fit(a.first, a.last);
          b.line = Fit(b.first, b.last);
          if (a.count() < 1 || b.count() < 1) {
            segs_.erase(segs_.begin() + (a.count() < 1 ? k : k + 1));
          }
          break;
        }
      }
    }
  }

  // Boundary points closer to the neighbour's line than to their own move there (a few passes).
  void RefineBoundaries() {
    for (int pass = 0; pass < 3; ++pass) {
      bool changed = false;
      for (size_t k = 0; k + 1 < segs_.size(); ++k) {
        Seg& a = segs_[k];
        Seg& b = segs_[k + 1];
        if (!a.line.ok || !b.line.ok || a.count() < 3 || b.count() < 3) continue;
        const ScanPoint& pa = pts_[a.last];
        const ScanPoint& pb = pts_[b.first];
        bool moved = false;
        if (a.count() > 3 &&
            std::abs(b.line.Distance(pa.x, pa.y)) < std::abs(a.line.Distance(pa.x, pa.y))) {
          --a.last;
          --b.first;
          moved = true;
        } else if (b.count() > 3 &&
                   std::abs(a.line.Distance(pb.x, pb.y)) < std::abs(b.line.Distance(pb.x, pb.y))) {
          ++a.last;
          ++b.first;
          moved = true;
        }
        if (moved) {
          a.line = Fit(a.first, a.last);
          b.line = Fit(b.first, b.last);
          changed = true;
        }
      }
      if (!changed) break;
    }
  }

  void ProcessCluster(int first, int last, std::vector<ObservedSegment>* out) {
    SplitCluster(first, last, &breaks_);
    segs_.clear();
    for (size_t k = 0; k + 1 < breaks_.size(); ++k) {
      Seg s;
      s.first = breaks_[k];
      s.last = breaks_[k + 1];
      s.line = Fit(s.first, s.last);
      segs_.push_back(s);
    }
    // Consecutive segments share their breakpoint: give it to the line it is closer to (to the
    // larger segment when either is too small for its line to mean anything).
    for (size_t k = 0; k + 1 < segs_.size(); ++k) {
      Seg& a = segs_[k];
      Seg& b = segs_[k + 1];
      if (a.last != b.first || a.count() < 1 || b.count() < 1) continue;
      const ScanPoint& p = pts_[a.last];
      bool to_a;
      if (a.count() >= 3 && b.count() >= 3 && a.line.ok && b.line.ok) {
        to_a = std::abs(a.line.Distance(p.x, p.y)) <= std::abs(b.line.Distance(p.x, p.y));
      } else {
        to_a = a.count() >= b.count();
      }
      if (to_a) {
        ++b.first;
      } else {
        --a.last;
      }
    }
    segs_.erase(
        std::remove_if(segs_.begin(), segs_.end(), [](const Seg& s) { return s.count() < 1; }),
        segs_.end());
    for (Seg& s : segs_) s.line = Fit(s.first, s.last);
    // Each step can enable another (a boundary move can leave a piece small, or make two pieces
    // mergeable), so run them twice.
    for (int round = 0; round < 2; ++round) {
      MergeNeighbours();
      RefineBoundaries();
      AbsorbSmallPieces();
    }
    MergeNeighbours();
    for (size_t k = 0; k < segs_.size(); ++k) {
      ObservedSegment seg;
      if (Finish(k, &seg)) out->push_back(seg);
    }
  }

  struct End {
    double tau = 0.0;
    double variance = 0.0;
    EndpointType type = EndpointType::kVirtual;
  };

  // One endpoint of segs_[k]: `dir` = -1 for the left (first beam), +1 for the right (last beam).
  //
  // Rule, looking at the beam b just beyond the endpoint:
  //  - VIRTUAL when b is outside the scan (field of view; a full-circle scan is not wrapped), or b
  //    is a no-return or out of range (the wall may go on unseen).
  //  - REAL (corner) when the adjacent segment of the same cluster (ending/starting at b, >= 3
  //    points, a valid line) makes an angle >= merge_angle with this line and the two lines
  //    intersect near the junction (within the gap to b plus split_distance along both lines). The
  //    endpoint is then that intersection.
  //  - Otherwise compare the point of beam b with the line's extension at b's bearing, across the
  //    line: d = rho - p_b . n (> 0: p_b is on the sensor's side, i.e. closer). With
  //    tol = max(split_distance, 3 sigma) (sigma: the reading's noise across the line plus the
  //    line's own uncertainty there):
  //      d > tol  (closer): an occluder in front, the wall may continue behind it -> VIRTUAL;
  //      d < -tol (farther): we see past the wall's end -> REAL; the endpoint is put half way
  //        between the last point's projection and beam b's crossing of the line (the true end lies
  //        uniformly in between), variance gap^2 / 12 plus the reading's noise along the line;
  //      else (p_b on the extension, ambiguous) -> VIRTUAL (a wrong REAL endpoint would pin the
  //        map's segment end; a wrong VIRTUAL one only delays it).
  // VIRTUAL endpoints are the projection of the extreme point; their variance is the reading's
  // noise along the line plus beam-spacing quantisation (r |increment|)^2 / (12 sin^2 incidence).
  End Endpoint(size_t k, int dir, double tau_other) const {
    const Seg& s = segs_[k];
    const PolarLine& l = s.line;
    const int e = dir < 0 ? s.first : s.last;
    const ScanPoint& p = pts_[e];
    const double cp = std::cos(l.phi), sp = std::sin(l.phi);
    const double ca = p.c * cp + p.s * sp;  // cos(a_e - phi)
    const double sa = p.s * cp - p.c * sp;  // sin(a_e - phi)
    const double noise_along = o_.range_sigma * o_.range_sigma * sa * sa +
                               p.r * p.r * o_.bearing_sigma * o_.bearing_sigma * ca * ca;
    const double sin_inc = std::max(std::abs(ca), 1e-3);
    const double spacing = p.r * inc_ / sin_inc;
    End end;
    end.tau = l.Tau(p.x, p.y);
    end.variance = noise_along + spacing * spacing / 12.0;
    const int b = e + dir;
    if (b < 0 || b >= n_ || state_[b] != BeamState::kPoint) return end;
    const ScanPoint& q = pts_[b];
    const double outward = end.tau >= tau_other ? 1.0 : -1.0;

    // Corner with the adjacent segment of the cluster.
    const long nk = static_cast<long>(k) + dir;
    if (nk >= 0 && nk < static_cast<long>(segs_.size())) {
      const Seg& nb = segs_[nk];
      const bool adjacent = dir < 0 ? nb.last == b : nb.first == b;
      if (adjacent && nb.line.ok && nb.count() >= 3 &&
          LineAngle(l.phi, nb.line.phi) >= o_.merge_angle) {
        Eigen::Matrix2d nmat;
        nmat << cp, sp, std::cos(nb.line.phi), std::sin(nb.line.phi);
        const double det = nmat.determinant();
        if (std::abs(det) > 1e-9) {
          const Eigen::Matrix2d ninv = nmat.inverse();
          const Eigen::Vector2d x = ninv * Eigen::Vector2d(l.rho, nb.line.rho);
          const double tau_x = l.Tau(x(0), x(1));
          const double gap = std::hypot(q.x - p.x, q.y - p.y);
          const double tol = gap + o_.split_distance;
          if (std::abs(tau_x - end.tau) <= tol &&
              std::abs(nb.line.Tau(x(0), x(1)) - nb.line.Tau(q.x, q.y)) <= tol) {
            end.type = EndpointType::kReal;
            end.tau = tau_x;
            // The intersection slides along this line as the neighbour's line moves:
            // dx = ninv.col(1) * (drho_nb - tau_nb(x) dphi_nb).
            const double g = Eigen::Vector2d(-sp, cp).dot(ninv.col(1));
            end.variance = g * g * LineVarianceAt(nb.line, nb.line.Tau(x(0), x(1))) + 1e-8;
            return end;
          }
        }
      }
    }

    // Beyond point against the line's extension.
    const double cb = q.c * cp + q.s * sp;  // cos(a_b - phi)
    const double sb = q.s * cp - q.c * sp;
    const double tau_b = l.Tau(q.x, q.y);
    const double sigma2 = o_.range_sigma * o_.range_sigma * cb * cb +
                          q.r * q.r * o_.bearing_sigma * o_.bearing_sigma * sb * sb +
                          LineVarianceAt(l, tau_b);
    const double tol = std::max(o_.split_distance, 3.0 * std::sqrt(sigma2));
    const double d = l.rho - (q.x * cp + q.y * sp);
    if (d < -tol) {
      end.type = EndpointType::kReal;
      if (cb > 1e-3) {
        // Where beam b crosses the line: the wall ended before it.
        const double tau_cross = l.rho * sb / cb;
        const double gap = tau_cross - end.tau;
        if (gap * outward > 0.0 && std::abs(gap) <= 3.0 * spacing + o_.split_distance) {
          end.tau += 0.5 * gap;
          end.variance = noise_along + gap * gap / 12.0;
        }
      }
    }
    return end;
  }

  bool Finish(size_t k, ObservedSegment* seg) const {
    const Seg& s = segs_[k];
    if (!s.line.ok || s.count() < o_.min_points) return false;
    const PolarLine& l = s.line;
    const double tau_first = l.Tau(pts_[s.first].x, pts_[s.first].y);
    const double tau_last = l.Tau(pts_[s.last].x, pts_[s.last].y);
    const End left = Endpoint(k, -1, tau_last);
    const End right = Endpoint(k, +1, tau_first);
    const double length = std::abs(right.tau - left.tau);
    if (length < o_.min_length || length <= 0.0) return false;
    const double sgn = right.tau > left.tau ? 1.0 : -1.0;
    const double tau_m = 0.5 * (left.tau + right.tau);
    double mx, my;
    PointOnLine(l, tau_m, &mx, &my);
    const double dist = std::hypot(mx, my);
    // Incidence: angle between the line and the beam to its midpoint; sin = |u . n| = rho / |m|.
    const double incidence = dist > 0.0 ? std::asin(std::min(1.0, l.rho / dist)) : 0.0;
    if (incidence < o_.min_incidence) return false;

    seg->frame = Pose2{mx, my, NormalizeAngle(l.phi + sgn * M_PI_2)};
    seg->left = -0.5 * length;
    seg->right = 0.5 * length;
    seg->left_type = left.type;
    seg->right_type = right.type;
    seg->left_variance = left.variance;
    seg->right_variance = right.variance;
    seg->rho = l.rho;
    seg->phi = l.phi;
    seg->polar_covariance = l.covariance;
    // The frame's y axis is s * n with s = -sgn. Moving the line by (drho, dphi) moves it along y
    // at the frame origin (abscissa tau_m from the foot of the perpendicular) by p_y = s (drho -
    // tau_m dphi) and turns it by p_theta = dphi.
    const double sy = -sgn;
    Eigen::Matrix2d j;
    j << sy, -sy * tau_m, 0.0, 1.0;
    seg->line_covariance = j * l.covariance * j.transpose();
    seg->first_beam = s.first;
    seg->last_beam = s.last;
    seg->point_count = s.count();
    return true;
  }

  const LineExtractionOptions& o_;
  const int n_;
  const double inc_;
  std::vector<ScanPoint> pts_;
  std::vector<BeamState> state_;
  std::vector<std::pair<int, int>> stack_;
  std::vector<int> breaks_;
  std::vector<Seg> segs_;
};

}  // namespace

absl::StatusOr<std::vector<ObservedSegment>> ExtractSegments(const LaserScan& scan,
                                                             const LineExtractionOptions& options) {
  if (absl::Status s = ValidateScanGeometry(scan.geometry); !s.ok()) return s;
  if (scan.ranges.size() != static_cast<size_t>(scan.geometry.beam_count)) {
    return absl::InvalidArgumentError(
        absl::StrCat("scan has ", scan.ranges.size(),
                     " ranges but its geometry says beam_count = ", scan.geometry.beam_count));
  }
  SlamOptions check;
  check.extraction = options;
  if (absl::Status s = ValidateSlamOptions(check); !s.ok()) return s;
  Extractor extractor(scan, options);
  return extractor.Run();
}

}  // namespace waymark::laser_slam
