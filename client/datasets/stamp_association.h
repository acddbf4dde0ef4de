#ifndef WAYMARK_CLIENT_DATASETS_STAMP_ASSOCIATION_H_
#define WAYMARK_CLIENT_DATASETS_STAMP_ASSOCIATION_H_

// Pairs two lists of time stamps (an estimate and its ground truth, RGB and depth frames), as the
// TUM RGB-D benchmark's associate.py does.

#include <cstddef>
#include <vector>

namespace waymark::cli {

// One estimated pose matched to one ground-truth pose (indices into the two inputs).
struct PoseMatch {
  size_t estimate = 0;
  size_t groundtruth = 0;
};

// Matches stamps like the TUM benchmark's associate.py: every pair closer than `max_dt` (and at
// most max_dt apart) is a candidate, candidates are taken greedily from the smallest time
// difference, each pose of either side used at most once. The result is ordered by estimated stamp.
// Inputs need not be sorted.
std::vector<PoseMatch> AssociateByStamp(const std::vector<double>& estimate_stamps,
                                        const std::vector<double>& groundtruth_stamps,
                                        double max_dt);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_STAMP_ASSOCIATION_H_
