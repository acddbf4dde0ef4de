#include "client/eval/vo_summary.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/eval/result_warnings.h"

namespace waymark::cli {

void WriteTumPoses(std::ostream& out, const std::vector<StampedPose3>& poses) {
  out << "# timestamp tx ty tz qx qy qz qw\n";
  for (const StampedPose3& pose : poses) {
    Eigen::Quaterniond q(pose.rotation);
    q.normalize();
    if (q.w() < 0) q.coeffs() = -q.coeffs();  // the same rotation; one sign for readability
    out << fmt::format("{:.6f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f}\n", pose.stamp,
                       pose.translation.x(), pose.translation.y(), pose.translation.z(), q.x(),
                       q.y(), q.z(), q.w());
  }
}

absl::Status WriteTumPosesFile(const std::filesystem::path& path,
                               const std::vector<StampedPose3>& poses) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError(absl::StrCat("cannot write '", path.string(), "'"));
  WriteTumPoses(out, poses);
  out.close();
  if (!out) return absl::DataLossError(absl::StrCat("writing '", path.string(), "' failed"));
  return absl::OkStatus();
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double position = std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(values.size() - 1, below + 1);
  const double fraction = position - static_cast<double>(below);
  return values[below] + fraction * (values[above] - values[below]);
}

std::vector<StampedPose3> ProcessedPoses(const std::vector<VoFrameRecord>& records) {
  std::vector<StampedPose3> poses;
  for (const VoFrameRecord& r : records) {
    if (r.answered && !r.rejected) poses.push_back(r.pose);
  }
  return poses;
}

nlohmann::json FrameSummary(const std::vector<VoFrameRecord>& records) {
  uint64_t processed = 0, rejected = 0, unanswered = 0, lost = 0, keyframes = 0;
  uint64_t total = 0, potentially_dynamic = 0, matched = 0, dynamic = 0, tracked = 0, mapped = 0;
  std::vector<std::vector<double>> stage_ms(kVoStages.size());
  std::vector<double> bundle_ms;  // per adjustment applied
  uint64_t relocalized = 0, tracked_frames = 0, weak_frames = 0;
  std::vector<double> inliers, parallax;  // over tracked frames
  for (const VoFrameRecord& r : records) {
    if (!r.answered) {
      ++unanswered;
      continue;
    }
    if (r.rejected) {
      ++rejected;
      continue;
    }
    ++processed;
    if (r.state == "lost") ++lost;
    if (r.keyframe) ++keyframes;
    total += r.total;
    potentially_dynamic += r.potentially_dynamic;
    matched += r.matched;
    dynamic += r.dynamic;
    tracked += r.tracked;
    mapped += r.mapped;
    for (size_t s = 0; s < kVoStages.size(); ++s) stage_ms[s].push_back(r.stage_ms[s]);
    if (r.bundle_ms > 0) bundle_ms.push_back(r.bundle_ms);
    if (r.relocalized) ++relocalized;
    if (r.state == "tracking") {
      ++tracked_frames;
      inliers.push_back(r.inliers);
      parallax.push_back(r.parallax_deg);
    }
    if (r.quality == "weak") ++weak_frames;
  }
  nlohmann::json json = {
      {"frames", records.size()},    {"processed", processed},
      {"rejected", rejected},        {"frames_unanswered", unanswered},
      {"lost_frames", lost},         {"keyframes", keyframes},
      {"features_total", total},     {"features_potentially_dynamic", potentially_dynamic},
      {"features_matched", matched}, {"features_dynamic", dynamic},
      {"features_tracked", tracked}, {"features_mapped", mapped},
      {"relocalized_frames", relocalized}, {"bundle_adjustments", bundle_ms.size()},
      {"bundle_ms_median", Quantile(bundle_ms, 0.5)}, {"bundle_ms_p90", Quantile(bundle_ms, 0.9)},
      {"tracked_frames", tracked_frames}, {"weak_frames", weak_frames},
      {"inliers_median", Quantile(inliers, 0.5)}, {"parallax_deg_median", Quantile(parallax, 0.5)},
  };
  for (size_t s = 0; s < kVoStages.size(); ++s) {
    json[fmt::format("{}_ms_median", kVoStages[s])] = Quantile(stage_ms[s], 0.5);
    json[fmt::format("{}_ms_p90", kVoStages[s])] = Quantile(stage_ms[s], 0.9);
  }
  return json;
}

nlohmann::json EvaluationSummary(const TrajectoryEvaluation& e, bool with_scale) {
  const std::optional<std::string> warning = FewMatchesWarning(e);
  nlohmann::json json = {
      {"match_warning", warning ? nlohmann::json(*warning) : nlohmann::json(nullptr)},
      {"alignment", with_scale ? "Sim(3)" : "SE(3)"},
      {"scale", e.alignment.scale},
      {"poses_matched", e.matches.size()},
      {"poses_groundtruth", e.poses_groundtruth},
      {"ate_rmse", e.ate.rmse},
      {"ate_mean", e.ate.mean},
      {"ate_median", e.ate.median},
      {"ate_std", e.ate.std},
      {"ate_max", e.ate.max},
      {"rpe_pairs", e.rpe_translation.count},
      {"rpe_trans_rmse", e.rpe_translation.rmse},
      {"rpe_trans_mean", e.rpe_translation.mean},
      {"rpe_trans_std", e.rpe_translation.std},
      {"rpe_rot_rmse_deg", e.rpe_rotation_deg.rmse},
      {"rpe_rot_mean_deg", e.rpe_rotation_deg.mean},
      {"rpe_rot_std_deg", e.rpe_rotation_deg.std},
      {"groundtruth_path_m", PathLength(e.groundtruth_positions)},
  };
  json.update(WarningsJson(EvaluationWarnings(e, with_scale)));
  return json;
}

std::string AteLine(const TrajectoryEvaluation& e, bool with_scale,
                    const std::vector<ResultWarning>& warnings) {
  const std::string mark = NotMeaningfulMark(warnings);
  return fmt::format(
      "ATE RMSE {:.4f} m over {} poses ({}{}), RPE trans RMSE {:.4f} m, rot RMSE {:.3f} deg",
      e.ate.rmse, e.matches.size(), with_scale ? "Sim(3)" : "SE(3)",
      mark.empty() ? "" : ", " + mark, e.rpe_translation.rmse, e.rpe_rotation_deg.rmse);
}

}  // namespace waymark::cli
