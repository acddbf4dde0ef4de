#include "client/eval/scan_clock_fit.h"

#include <algorithm>
#include <cmath>

#include "absl/status/status.h"

namespace waymark::cli {
namespace {

constexpr double kLocalRelationS = 10.0;
// A relation further off than this (m, with 0.5 m per rad) counts as this much: a scan where the
// odometry slipped, or a relation to a scan the fit misses, must not pull the fit.
constexpr double kCostCap = 1.0;

struct Candidate {
  double period = 0;
  double offset = 0;
  double cost = INFINITY;
};

int IndexAt(double stamp, double t0, double period, double offset, int scans) {
  const double index = std::round((stamp - t0) / period + offset);
  if (!(index >= 0 && index < scans)) return -1;
  return static_cast<int>(index);
}

double Cost(const std::vector<Pose2>& odometry, const std::vector<const Relation*>& relations,
            double t0, double period, double offset) {
  const int scans = static_cast<int>(odometry.size());
  double sum = 0;
  for (const Relation* r : relations) {
    const int a = IndexAt(r->t1, t0, period, offset, scans);
    const int b = IndexAt(r->t2, t0, period, offset, scans);
    if (a < 0 || b < 0) {
      sum += kCostCap;
      continue;
    }
    const Pose2 e = Compose(Inverse(r->delta), Compose(Inverse(odometry[a]), odometry[b]));
    sum += std::min(kCostCap, std::hypot(e.x, e.y) + 0.5 * std::abs(NormalizeAngle(e.theta)));
  }
  return sum / static_cast<double>(relations.size());
}

// The best (period, offset) over a grid: periods p0 * (1 + k * step) for k in [0, steps], offsets
// by `offset_step`: within offset_radius of offset_centre, or (radius 0) every offset that keeps
// the relations inside the log, give or take 2 scans.
Candidate Search(const std::vector<Pose2>& odometry, const std::vector<const Relation*>& relations,
                 double t0, double span, double p0, double step, int steps, double offset_step,
                 double offset_centre, double offset_radius) {
  Candidate best;
  const double last = static_cast<double>(odometry.size()) - 1;
  for (int k = 0; k <= steps; ++k) {
    const double period = p0 * (1.0 + k * step);
    double from = -2.0, to = last - span / period + 2.0;
    if (offset_radius > 0) {
      from = offset_centre - offset_radius;
      to = offset_centre + offset_radius;
    }
    for (double offset = from; offset <= to + 1e-9; offset += offset_step) {
      const double cost = Cost(odometry, relations, t0, period, offset);
      if (cost < best.cost) best = {period, offset, cost};
    }
  }
  return best;
}

}  // namespace

int ScanClockFit::IndexOf(double stamp, int scans) const {
  return IndexAt(stamp, t0, period, offset, scans);
}

absl::StatusOr<ScanClockFit> FitScanClock(const std::vector<Pose2>& odometry,
                                          const std::vector<Relation>& relations,
                                          double max_period_ratio) {
  if (odometry.size() < 2) return absl::InvalidArgumentError("fewer than 2 scans");
  std::vector<const Relation*> local;
  double t0 = INFINITY, t_end = -INFINITY;
  for (const Relation& r : relations) {
    t0 = std::min({t0, r.t1, r.t2});
    t_end = std::max({t_end, r.t1, r.t2});
    if (std::abs(r.t2 - r.t1) <= kLocalRelationS) local.push_back(&r);
  }
  if (local.empty()) return absl::InvalidArgumentError("no relation within 10 s");
  const double span = t_end - t0;
  const double p_min = span / static_cast<double>(odometry.size() - 1);
  if (!(p_min > 0)) return absl::InvalidArgumentError("the relations span no time");

  // Coarse: about 600 relations, periods 1e-4 apart (relative), whole scans.
  std::vector<const Relation*> coarse;
  const size_t stride = std::max<size_t>(1, local.size() / 600);
  for (size_t i = 0; i < local.size(); i += stride) coarse.push_back(local[i]);
  constexpr double kCoarseStep = 1e-4;
  const int coarse_steps = static_cast<int>(std::ceil((max_period_ratio - 1.0) / kCoarseStep));
  const Candidate c = Search(odometry, coarse, t0, span, p_min, kCoarseStep, coarse_steps, 1.0, 0, 0);

  // Fine: every local relation, periods 1e-5 apart within two coarse steps, offsets by 0.05 scan.
  constexpr double kFineStep = 1e-5;
  const double p_from = c.period * (1.0 - 2 * kCoarseStep);
  const Candidate f = Search(odometry, local, t0, span, p_from, kFineStep,
                             static_cast<int>(4 * kCoarseStep / kFineStep), 0.05, c.offset, 2.0);

  ScanClockFit fit;
  fit.t0 = t0;
  fit.period = f.period;
  fit.offset = f.offset;
  fit.cost = f.cost;
  fit.cost_minus_one = Cost(odometry, local, t0, f.period, f.offset - 1.0);
  fit.cost_plus_one = Cost(odometry, local, t0, f.period, f.offset + 1.0);
  fit.local_relations = static_cast<int>(local.size());
  return fit;
}

std::vector<Relation> RestampRelations(const std::vector<Relation>& relations,
                                       const ScanClockFit& fit,
                                       const std::vector<double>& scan_stamps, int* dropped) {
  std::vector<Relation> out;
  int left_out = 0;
  const int scans = static_cast<int>(scan_stamps.size());
  for (const Relation& r : relations) {
    const int a = fit.IndexOf(r.t1, scans);
    const int b = fit.IndexOf(r.t2, scans);
    if (a < 0 || b < 0) {
      ++left_out;
      continue;
    }
    Relation moved = r;
    moved.t1 = scan_stamps[a];
    moved.t2 = scan_stamps[b];
    out.push_back(moved);
  }
  if (dropped != nullptr) *dropped = left_out;
  return out;
}

}  // namespace waymark::cli
