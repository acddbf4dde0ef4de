#include "client/eval/result_warnings.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace waymark::cli {

double PathLength(const std::vector<Eigen::Vector3d>& positions) {
  double length = 0;
  for (size_t i = 1; i < positions.size(); ++i) length += (positions[i] - positions[i - 1]).norm();
  return length;
}

std::vector<ResultWarning> EvaluationWarnings(const TrajectoryEvaluation& e, bool with_scale) {
  std::vector<ResultWarning> out;
  const double scale = e.alignment.scale;
  if (with_scale && !(scale >= kMinSim3Scale && scale <= kMaxSim3Scale)) {
    out.push_back({"scale", fmt::format("the Sim(3) alignment scaled the estimate by {:.4g}, outside "
                                        "[{}, {}]: it was shrunk or stretched to fit, and the ATE "
                                        "measures that, not the estimate",
                                        scale, kMinSim3Scale, kMaxSim3Scale)});
  }
  const double truth_path = PathLength(e.groundtruth_positions);
  double truth_rotation_deg = 0;
  for (size_t i = 1; i < e.groundtruth_rotations.size(); ++i) {
    truth_rotation_deg +=
        RotationAngle(e.groundtruth_rotations[i - 1].transpose() * e.groundtruth_rotations[i]) *
        180 / M_PI;
  }
  if (truth_path < kMinGroundTruthPathM) {
    if (truth_rotation_deg > kPureRotationDeg) {
      out.push_back({"degenerate_motion",
                     fmt::format("the ground truth turns {:.0f} degrees but moves only {:.3f} m "
                                 "(under {} m): a pure rotation, which gives a monocular camera "
                                 "no parallax to measure a translation from",
                                 truth_rotation_deg, truth_path, kMinGroundTruthPathM)});
    }
    out.push_back({"short_groundtruth",
                   fmt::format("the ground truth's path over the matched poses is {:.3f} m, "
                               "under the {} m minimum: errors are as large as the motion",
                               truth_path, kMinGroundTruthPathM)});
  }
  const double aligned_path = PathLength(e.aligned_positions);
  if (truth_path > 0 && aligned_path < kCollapsedPathShare * truth_path) {
    out.push_back({"degenerate_motion",
                   fmt::format("the aligned estimate moves {:.3f} m against the ground truth's "
                               "{:.3f} m: the estimated motion collapsed (no motion or no "
                               "parallax found)",
                               aligned_path, truth_path)});
  }
  if (const std::optional<std::string> few = FewMatchesWarning(e)) {
    out.push_back({"few_matches", *few});
  }
  return out;
}

std::vector<ResultWarning> TrackingWarnings(const std::vector<VoFrameRecord>& records,
                                            bool monocular) {
  std::vector<ResultWarning> out;
  size_t processed = 0, tracked = 0, no_parallax = 0;
  std::vector<std::string> session_warnings;
  for (const VoFrameRecord& r : records) {
    for (const std::string& w : r.warnings) {
      if (std::find(session_warnings.begin(), session_warnings.end(), w) ==
          session_warnings.end()) {
        session_warnings.push_back(w);
      }
    }
    if (!r.answered || r.rejected) continue;
    ++processed;
    if (r.state != "tracking") continue;
    ++tracked;
    if (r.quality == "weak" && r.parallax_deg < kLowParallaxDegForSummary) ++no_parallax;
  }
  for (const std::string& w : session_warnings) out.push_back({"camera", w});
  if (processed > 0 && tracked < kMinTrackedShare * static_cast<double>(processed)) {
    out.push_back({"few_tracked", fmt::format("only {} of {} processed frames were tracked (under "
                                              "{:.0f} %): the rest are predictions",
                                              tracked, processed, 100 * kMinTrackedShare)});
  }
  if (monocular && tracked > 0 && no_parallax > kLowParallaxShare * static_cast<double>(tracked)) {
    out.push_back({"degenerate_motion",
                   fmt::format("{} of {} tracked frames had no parallax (median under {} "
                               "degrees): the camera turned or stood still, and a monocular "
                               "translation is a guess there",
                               no_parallax, tracked, kLowParallaxDegForSummary)});
  }
  return out;
}

nlohmann::json WarningsJson(const std::vector<ResultWarning>& warnings) {
  nlohmann::json list = nlohmann::json::array();
  for (const ResultWarning& w : warnings) list.push_back({{"code", w.code}, {"message", w.message}});
  return {{"warnings", list}, {"result_meaningful", warnings.empty()}};
}

std::string NotMeaningfulMark(const std::vector<ResultWarning>& warnings,
                              const std::string& where) {
  return warnings.empty() ? "" : "NOT MEANINGFUL: see " + where;
}

}  // namespace waymark::cli
