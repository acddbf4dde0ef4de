#ifndef WAYMARK_CLIENT_SESSIONS_VO_PICTURES_H_
#define WAYMARK_CLIENT_SESSIONS_VO_PICTURES_H_

// Pictures of a visual odometry run (`waymark vo run`):
// - a frame with its features coloured by what the dynamic-point filter made of them (static
//   green, static inside a box blue, dynamic red, potentially dynamic yellow, unmatched grey) and
//   the detector boxes with their labels;
// - the trajectory seen from above (the x-z plane of the first camera: x right, z forward), with
//   the ground truth brought into that frame by the ATE alignment when there is one.

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/render/map_render.h"
#include "client/eval/trajectory_metrics.h"
#include "client/render/vo_frames.h"

namespace waymark::cli {

// BGR colour of a feature label (exact: features are drawn without anti-aliasing).
cv::Scalar FeatureColor(VoFeatureLabel label);
// Colour of the detector boxes.
cv::Scalar BoxColor();

// The image (gray or colour, 8-bit) as colour, with boxes, features (filled discs of radius 3)
// and `caption` in a band at the top-left. INVALID_ARGUMENT for an empty or non-8-bit image.
absl::StatusOr<cv::Mat> DrawFeatureFrame(const cv::Mat& image,
                                         const std::vector<VoFeature>& features,
                                         const std::vector<VoBox>& boxes,
                                         const std::string& caption);

// Reads `image_path`, draws the frame and writes it as PNG to `out_path`.
absl::Status WriteFeatureFrame(const std::filesystem::path& image_path, const VoFrameRecord& record,
                               const std::string& caption, const std::filesystem::path& out_path);

// The top-view scene: the estimate's x-z path with start and end markers and the camera's last
// pose as an arrow along its viewing direction, and, with an evaluation, the matched ground-truth
// positions mapped into the estimate's frame by the inverse of the alignment (with their own
// start and end markers).
MapScene TrajectoryScene(const std::vector<StampedPose3>& estimate,
                         const std::optional<TrajectoryEvaluation>& evaluation,
                         const std::string& title);

// How the trajectory is drawn: no segment legend (a camera has no segment map) and a view down
// to 5 cm each way (a hand-held camera moves centimetres, a building map needs metres).
RenderOptions TrajectoryRenderOptions();

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_VO_PICTURES_H_
