#include "client/sessions/vo_pictures.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace waymark::cli {
namespace {

constexpr int kFeatureRadius = 3;
constexpr double kFontScale = 0.45;
// Height of the caption band at the top (box labels stay below it).
constexpr int kCaptionBand = 22;

// Text with a dark outline so it reads on any background.
void PutLabel(cv::Mat& image, const std::string& text, cv::Point at, const cv::Scalar& color) {
  cv::putText(image, text, at, cv::FONT_HERSHEY_SIMPLEX, kFontScale, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(image, text, at, cv::FONT_HERSHEY_SIMPLEX, kFontScale, color, 1, cv::LINE_AA);
}

}  // namespace

cv::Scalar FeatureColor(VoFeatureLabel label) {
  switch (label) {
    case VoFeatureLabel::kStatic:
      return cv::Scalar(0, 200, 0);  // green
    case VoFeatureLabel::kStaticInBox:
      return cv::Scalar(255, 80, 0);  // blue
    case VoFeatureLabel::kDynamic:
      return cv::Scalar(0, 0, 255);  // red
    case VoFeatureLabel::kPotentiallyDynamic:
      return cv::Scalar(0, 230, 255);  // yellow
    case VoFeatureLabel::kUnmatched:
      break;
  }
  return cv::Scalar(150, 150, 150);  // grey
}

cv::Scalar BoxColor() { return cv::Scalar(255, 0, 255); }  // magenta: unlike any feature colour

absl::StatusOr<cv::Mat> DrawFeatureFrame(const cv::Mat& image,
                                         const std::vector<VoFeature>& features,
                                         const std::vector<VoBox>& boxes,
                                         const std::string& caption) {
  if (image.empty()) return absl::InvalidArgumentError("empty image");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    return absl::InvalidArgumentError("expected an 8-bit gray or colour image");
  }
  cv::Mat out;
  if (image.channels() == 1) {
    cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  } else {
    out = image.clone();
  }
  for (const VoBox& box : boxes) {
    const cv::Rect rect(cvRound(box.x), cvRound(box.y), cvRound(box.w), cvRound(box.h));
    cv::rectangle(out, rect, BoxColor(), 2, cv::LINE_8);
    std::string text = box.label.empty() ? "box" : box.label;
    if (box.confidence > 0) text += fmt::format(" {:.2f}", box.confidence);
    // Above the box, or inside it below the caption band when the box starts at the top edge
    // (people close to the camera are cut by it).
    const int label_y =
        rect.y - 4 >= kCaptionBand + 12 ? rect.y - 4 : std::max(rect.y, kCaptionBand) + 14;
    PutLabel(out, text, cv::Point(std::max(0, rect.x) + 2, label_y), BoxColor());
  }
  // Grey first, so the informative colours are on top where features overlap.
  std::vector<const VoFeature*> order;
  for (const VoFeature& f : features) order.push_back(&f);
  std::stable_sort(order.begin(), order.end(), [](const VoFeature* a, const VoFeature* b) {
    return (a->label == VoFeatureLabel::kUnmatched) > (b->label == VoFeatureLabel::kUnmatched);
  });
  for (const VoFeature* f : order) {
    // No anti-aliasing: the disc's centre has exactly the label's colour.
    cv::circle(out, cv::Point(cvRound(f->x), cvRound(f->y)), kFeatureRadius, FeatureColor(f->label),
               cv::FILLED, cv::LINE_8);
  }
  if (!caption.empty()) {
    // Shrunk to the image width rather than cut off.
    int baseline = 0;
    double scale = kFontScale;
    cv::Size size = cv::getTextSize(caption, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
    if (size.width > out.cols - 8 && size.width > 0) {
      scale *= static_cast<double>(out.cols - 8) / size.width;
      size = cv::getTextSize(caption, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
    }
    cv::rectangle(out,
                  cv::Rect(0, 0, std::min(out.cols, size.width + 8), size.height + baseline + 8),
                  cv::Scalar(0, 0, 0), cv::FILLED);
    cv::putText(out, caption, cv::Point(4, size.height + 4), cv::FONT_HERSHEY_SIMPLEX, scale,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  // Legend along the bottom edge.
  int x = 4;
  const int y = out.rows - 6;
  for (VoFeatureLabel label :
       {VoFeatureLabel::kStatic, VoFeatureLabel::kStaticInBox, VoFeatureLabel::kDynamic,
        VoFeatureLabel::kPotentiallyDynamic, VoFeatureLabel::kUnmatched}) {
    const std::string name = VoFeatureLabelName(label);
    cv::circle(out, cv::Point(x + 4, y - 4), kFeatureRadius, FeatureColor(label), cv::FILLED,
               cv::LINE_8);
    PutLabel(out, name, cv::Point(x + 11, y), FeatureColor(label));
    int baseline = 0;
    x += 20 + cv::getTextSize(name, cv::FONT_HERSHEY_SIMPLEX, kFontScale, 1, &baseline).width;
  }
  return out;
}

absl::Status WriteFeatureFrame(const std::filesystem::path& image_path, const VoFrameRecord& record,
                               const std::string& caption, const std::filesystem::path& out_path) {
  try {
    const cv::Mat image = cv::imread(image_path.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("cannot decode '", image_path.string(), "' as an image"));
    }
    cv::Mat image8 = image;
    if (image.depth() != CV_8U) image.convertTo(image8, CV_8U, 1.0 / 256);
    if (image8.channels() == 4) cv::cvtColor(image8, image8, cv::COLOR_BGRA2BGR);
    absl::StatusOr<cv::Mat> drawn =
        DrawFeatureFrame(image8, record.features, record.boxes, caption);
    if (!drawn.ok()) {
      return absl::Status(drawn.status().code(),
                          absl::StrCat(image_path.string(), ": ", drawn.status().message()));
    }
    if (!cv::imwrite(out_path.string(), *drawn)) {
      return absl::PermissionDeniedError(absl::StrCat("cannot write '", out_path.string(), "'"));
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("drawing ", out_path.string(), ": ", e.what()));
  }
  return absl::OkStatus();
}

MapScene TrajectoryScene(const std::vector<StampedPose3>& estimate,
                         const std::optional<TrajectoryEvaluation>& evaluation,
                         const std::string& title) {
  MapScene scene;
  scene.title = title;
  if (evaluation && !evaluation->groundtruth_positions.empty()) {
    // alignment maps estimate -> ground truth: p_gt = s R p + t, so p = R^T (p_gt - t) / s.
    const Similarity3& a = evaluation->alignment;
    const double scale = a.scale != 0 ? a.scale : 1.0;
    ScenePolyline truth{{}, Rgb{40, 40, 40}, 2.0, "ground truth (aligned)", /*mark_ends=*/true};
    for (const Eigen::Vector3d& p : evaluation->groundtruth_positions) {
      const Eigen::Vector3d q = a.rotation.transpose() * (p - a.translation) / scale;
      truth.points.push_back({q.x(), q.z()});
    }
    scene.references.push_back(std::move(truth));
  }
  ScenePolyline path{{}, Rgb{220, 40, 40}, 1.5, "estimate (x right, z forward)",
                     /*mark_ends=*/true};
  for (const StampedPose3& pose : estimate) {
    path.points.push_back({pose.translation.x(), pose.translation.z()});
  }
  if (!estimate.empty()) {
    // Where the camera looks (its z axis), seen from above.
    const Eigen::Vector3d forward = estimate.back().rotation.col(2);
    scene.current_pose = ScenePose{path.points.back(), std::atan2(forward.z(), forward.x()),
                                   path.color, "current pose (camera heading)"};
  }
  scene.polylines.push_back(std::move(path));
  return scene;
}

RenderOptions TrajectoryRenderOptions() {
  RenderOptions options;
  options.min_extent_m = 0.05;
  options.segment_legend = false;
  return options;
}

}  // namespace waymark::cli
