#ifndef WAYMARK_CLIENT_EVAL_RESULT_WARNINGS_H_
#define WAYMARK_CLIENT_EVAL_RESULT_WARNINGS_H_

// When a trajectory score means nothing (issue 35). `eval ate`, `vo run` and their summaries warn,
// and mark the summary (`warnings`, `result_meaningful: false`), when:
// - the Sim(3) scale is outside [kMinSim3Scale, kMaxSim3Scale]: the alignment shrank or blew up the
//   estimate to fit (a camera that barely moved, intrinsics of another camera); the ATE then
//   measures the ground truth's spread, not the estimate;
// - the ground truth's path over the matched poses is shorter than kMinGroundTruthPathM: errors
//   are as large as the motion;
// - the estimated motion is degenerate: the aligned estimate covers less than
//   kCollapsedPathShare of the ground truth's path (it collapsed to a point), or the ground truth
//   itself is a pure rotation (path under the minimum, rotation over kPureRotationDeg);
// - (`vo run`) fewer than kMinTrackedShare of the frames were tracked, or (monocular) most tracked
//   frames had no parallax (VisualTrackingQuality WEAK for parallax).

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "client/eval/trajectory_metrics.h"
#include "client/render/vo_frames.h"

namespace waymark::cli {

inline constexpr double kMinSim3Scale = 0.2;
inline constexpr double kMaxSim3Scale = 5.0;
inline constexpr double kMinGroundTruthPathM = 0.1;
inline constexpr double kCollapsedPathShare = 0.1;
inline constexpr double kPureRotationDeg = 10;
inline constexpr double kMinTrackedShare = 0.5;
inline constexpr double kLowParallaxShare = 0.5;
// The server's VisualTrackingQuality threshold (server/visual_slam/types.h kLowParallaxDeg).
inline constexpr double kLowParallaxDegForSummary = 0.05;

struct ResultWarning {
  std::string code;     // "scale", "short_groundtruth", "degenerate_motion", "few_tracked", ...
  std::string message;  // one sentence for people
};

// Path length (sum of consecutive distances) of a polyline.
double PathLength(const std::vector<Eigen::Vector3d>& positions);

// From the evaluation alone (`eval ate` and `vo run`); `with_scale`: Sim(3).
std::vector<ResultWarning> EvaluationWarnings(const TrajectoryEvaluation& evaluation,
                                              bool with_scale);

// From the answers of a `vo run` (processed frames only); `monocular`: no depth sent.
std::vector<ResultWarning> TrackingWarnings(const std::vector<VoFrameRecord>& records,
                                            bool monocular);

// {"warnings": [{"code": ..., "message": ...}, ...], "result_meaningful": warnings.empty()}.
nlohmann::json WarningsJson(const std::vector<ResultWarning>& warnings);

// The mark a printed score carries on its own line when `warnings` say it means nothing (issue
// 35's tour: the warnings came before an unmarked "ATE RMSE 0.0563 m"): "NOT MEANINGFUL: see
// <where>", or "" without warnings.
std::string NotMeaningfulMark(const std::vector<ResultWarning>& warnings,
                              const std::string& where = "warnings above");

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_RESULT_WARNINGS_H_
