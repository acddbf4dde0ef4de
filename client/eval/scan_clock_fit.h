#ifndef WAYMARK_CLIENT_EVAL_SCAN_CLOCK_FIT_H_
#define WAYMARK_CLIENT_EVAL_SCAN_CLOCK_FIT_H_

// Relations onto a log whose stamps were regenerated (MIT Killian in ../shared: MOLA rewrote its
// rawlog's stamps at a uniform 0.9 s, so Kummerle's relations, which name the original ipc stamps,
// match no scan). The scans are still the original ones, in order, with the original odometry, and
// that log's laser ran at a steady rate: scan i was taken at about t0 + period * (i - offset). The
// fit finds period and offset as the pair under which the odometry between the scans a relation
// names agrees best with the relation, over the local relations (t2 - t1 <= 10 s, where odometry
// is good). A relation names two times, so an offset one scan off still lets straight stretches
// agree; turns decide it, and the fit reports how much worse one scan either way scores
// (`sharpness`), which says how well the clock is pinned.

#include <vector>

#include "absl/status/statusor.h"
#include "client/eval/relations_metric.h"

namespace waymark::cli {

struct ScanClockFit {
  double t0 = 0;        // the relations' earliest stamp
  double period = 0;    // s per scan
  double offset = 0;    // scan index (fractional) at t0
  double cost = 0;      // mean capped disagreement (m + 0.5 m/rad) over the local relations
  double cost_minus_one = 0;  // the same with offset - 1 and offset + 1: how sharp the minimum is
  double cost_plus_one = 0;
  int local_relations = 0;  // relations the fit used
  // The scan index of a stamp under the fit (nearest), or -1 outside [0, scans).
  int IndexOf(double stamp, int scans) const;
};

// `odometry[i]` is scan i's odometry pose, in log order. Searches periods from the relations' span
// over (scans - 1) (the relations cover the whole log) up to `max_period_ratio` times that, coarse
// then fine. INVALID_ARGUMENT without local relations or with fewer than 2 scans.
absl::StatusOr<ScanClockFit> FitScanClock(const std::vector<Pose2>& odometry,
                                          const std::vector<Relation>& relations,
                                          double max_period_ratio = 1.02);

// The relations with each stamp replaced by the stamp of the scan the fit names; relations with a
// stamp outside the log are left out (counted in `dropped`).
std::vector<Relation> RestampRelations(const std::vector<Relation>& relations,
                                       const ScanClockFit& fit,
                                       const std::vector<double>& scan_stamps, int* dropped);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_SCAN_CLOCK_FIT_H_
