#ifndef WAYMARK_SERVER_CROSSING_DECISION_H_
#define WAYMARK_SERVER_CROSSING_DECISION_H_

// Steps 6-9 and the clustering rule of METHODS.md section 1, as pure functions.

#include <vector>

namespace waymark::crossing {

// Des_i = alpha * M_i / M_max + beta * S_i / S_max for the views kept after step 6. (The paper
// prints d_i / d_max; its own tables are reproduced only by S_i / S_max, see METHODS.md.)
// A term whose maximum is <= 0 contributes 0 (no view has matches, or every histogram is
// disjoint from the query's), so the other term decides.
// M is real-valued: the match count in the paper's and the verified mode, -log10 NFA in the
// retrieval mode.
std::vector<double> DecisionValues(const std::vector<double>& matches,
                                   const std::vector<double>& similarities, double alpha,
                                   double beta);

// Index of the largest value; the first on ties (so the view with more matches wins, as the
// list is sorted by matches). -1 for an empty list.
int ArgMax(const std::vector<double>& values);

// Threshold segmentation: given a new view's match counts against the existing cluster centres
// (in cluster creation order), the cluster it joins (argmax, first on ties) or -1 if the best
// count is below `threshold` and the view becomes a new centre.
int AssignCluster(const std::vector<int>& matches_per_center, int threshold);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_DECISION_H_
