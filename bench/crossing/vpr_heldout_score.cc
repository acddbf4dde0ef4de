#include "bench/crossing/vpr_heldout_score.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace waymark::vpr {

Replayed Replay(const HeldOutRow& row, double max_log10_global_efa, int model) {
  if (row.nfa_recognized) return {true, row.nfa_correct};
  const double efa = model < static_cast<int>(row.efa_by_model.size())
                         ? row.efa_by_model[model]
                         : (row.global_computed ? row.global_log10_efa : std::nan(""));
  if (std::isfinite(efa) && efa < max_log10_global_efa) return {true, row.global_correct};
  return {};
}

Replayed Today(const HeldOutRow& row) { return {row.today_recognized, row.today_correct}; }

std::vector<LeaveOneOut> LeaveOneSetOut(const std::vector<HeldOutRow>& rows,
                                        const std::vector<double>& grid, double max_false_accept) {
  std::set<std::string> sets;
  for (const HeldOutRow& r : rows) sets.insert(r.set);
  std::vector<double> sorted = grid;
  std::sort(sorted.begin(), sorted.end());  // strictest first
  std::vector<LeaveOneOut> out;
  for (const std::string& left : sets) {
    LeaveOneOut loo;
    loo.left_out = left;
    double best_recall = -1;
    for (int model = 0; model < static_cast<int>(std::size(kModels)); ++model) {
      for (double eps : sorted) {
        const auto scores =
            Score(rows, [eps, model](const HeldOutRow& r) { return Replay(r, eps, model); });
        bool ok = true;
        double recall = 0;
        int n = 0;
        for (const auto& [set, s] : scores) {
          if (set == left) continue;
          if (s.unknown > 0 && s.false_accept_rate() > max_false_accept) ok = false;
          if (s.known > 0) {
            recall += s.recall();
            ++n;
          }
        }
        if (!ok) continue;
        recall = n ? recall / n : 0;
        if (recall > best_recall + 1e-12) {
          best_recall = recall;
          loo.chosen_log10_efa = eps;
          loo.chosen_model = model;
        }
      }
    }
    loo.feasible = best_recall >= 0;
    if (!loo.feasible) loo.chosen_log10_efa = sorted.empty() ? 0 : sorted.front();
    const double eps = loo.chosen_log10_efa;
    const int model = loo.chosen_model;
    loo.held_out = Score(rows, [eps, model](const HeldOutRow& r) {
      return Replay(r, eps, model);
    })[left];
    out.push_back(loo);
  }
  return out;
}

}  // namespace waymark::vpr
