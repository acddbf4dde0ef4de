#ifndef WAYMARK_CLIENT_EVAL_VO_SUMMARY_H_
#define WAYMARK_CLIENT_EVAL_VO_SUMMARY_H_

// The results of a `waymark vo run` that are not pictures: the TUM trajectory file and
// summary.json (frame and feature counts, per-stage timings, ATE/RPE against ground truth).

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <vector>

#include "absl/status/status.h"
#include "client/eval/result_warnings.h"
#include "client/eval/trajectory_metrics.h"
#include "client/render/vo_frames.h"

namespace waymark::cli {

// `stamp tx ty tz qx qy qz qw` per pose (the TUM RGB-D format, read back by pose_file.h); stamps
// with microsecond precision, positions and quaternions with 9 decimals. qw >= 0.
void WriteTumPoses(std::ostream& out, const std::vector<StampedPose3>& poses);
absl::Status WriteTumPosesFile(const std::filesystem::path& path,
                               const std::vector<StampedPose3>& poses);

// The q-quantile (0..1) with linear interpolation between order statistics (numpy's default);
// 0 for no values.
double Quantile(std::vector<double> values, double q);

// The poses of the frames that were processed (answered without a rejection), in frame order.
std::vector<StampedPose3> ProcessedPoses(const std::vector<VoFrameRecord>& records);

// summary.json's frame part: frames (sent), processed, rejected, lost_frames, keyframes,
// frames_unanswered, feature count totals (features_total, ..._mapped), and per stage
// `<stage>_ms_median` / `<stage>_ms_p90` over processed frames.
nlohmann::json FrameSummary(const std::vector<VoFrameRecord>& records);

// The ATE/RPE fields, named as `waymark eval ate --json` names them (ate_rmse, ..., poses_matched,
// scale), and match_warning: FewMatchesWarning's text, or null when enough poses matched;
// groundtruth_path_m, and `warnings` / `result_meaningful` (result_warnings.h EvaluationWarnings).
nlohmann::json EvaluationSummary(const TrajectoryEvaluation& evaluation, bool with_scale);

// `vo run`'s score line: "ATE RMSE 0.0563 m over 51 poses (Sim(3)), RPE trans RMSE ... deg", with
// "(Sim(3), NOT MEANINGFUL: see warnings above)" when `warnings` (result_warnings.h) say so.
std::string AteLine(const TrajectoryEvaluation& evaluation, bool with_scale,
                    const std::vector<ResultWarning>& warnings);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_VO_SUMMARY_H_
