#ifndef WAYMARK_SERVER_CROSSING_FEATURES_H_
#define WAYMARK_SERVER_CROSSING_FEATURES_H_

// What the recognition method knows about one image: SIFT keypoints and descriptors at the working
// resolution, and the hue histogram.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "server/crossing/options.h"

namespace waymark::crossing {

inline constexpr int kDescriptorSize = 128;

struct ImageFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;          // N x 128, CV_8U (OpenCV's SIFT values are integers in [0, 255])
  std::vector<float> hue_hist;  // normalised
  int width = 0;                // working resolution the features were extracted at
  int height = 0;
  // With FeatureOptions::global_descriptor: dense RootSIFT (N x 128 CV_8U) and the grey image at
  // working resolution it was computed from (CV_8U). Empty otherwise.
  cv::Mat dense;
  cv::Mat working_gray;
};

// Keypoint positions (what geometric verification needs of a stored view).
std::vector<cv::Point2f> KeypointPositions(const ImageFeatures& features);

// Decodes JPEG/PNG bytes into a BGR image. INVALID_ARGUMENT for empty, corrupt or undecodable
// bytes, or images smaller than 8x8 (nothing to recognize).
absl::StatusOr<cv::Mat> DecodeImage(const std::string& bytes);

// The size an image of `image` size is extracted at: work_width x work_height (the paper's fixed
// frame), or with keep_aspect the largest size of the image's aspect ratio that fits into it.
cv::Size WorkingSize(cv::Size image, const FeatureOptions& options);

// Resizes to the working size (a plain resize by default, as the paper's fixed 320x240 frames).
cv::Mat ToWorkingResolution(const cv::Mat& bgr, const FeatureOptions& options);

// RootSIFT in place on N x 128 CV_8U SIFT descriptors (see FeatureOptions::root_sift).
void ToRootSift(cv::Mat* descriptors);

// SIFT (OpenCV, nOctaveLayers = 3, i.e. 6 images per octave as the paper) on the working-resolution
// image. An image without texture gives zero keypoints, not an error.
absl::StatusOr<ImageFeatures> ExtractSift(const cv::Mat& working_bgr, const FeatureOptions& options);

// Decode + resize + SIFT + hue histogram (+ dense RootSIFT), with the time each stage took.
struct ExtractionTimings {
  double decode_ms = 0;
  double extraction_ms = 0;
  double histogram_ms = 0;
  // Dense RootSIFT, with FeatureOptions::global_descriptor; it runs beside the SIFT extraction,
  // so the two overlap in time.
  double dense_ms = 0;
};
absl::StatusOr<ImageFeatures> ExtractFeatures(const std::string& encoded,
                                              const FeatureOptions& options,
                                              ExtractionTimings* timings = nullptr);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_FEATURES_H_
