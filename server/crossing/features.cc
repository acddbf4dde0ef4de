#include "server/crossing/features.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <future>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "server/crossing/dense_sift.h"
#include "server/crossing/hue_histogram.h"
#include "server/common/image_header.h"
#include "server/common/stopwatch.h"

namespace waymark::crossing {
namespace {

constexpr int kMinImageSide = 8;
// Decoding refuses images with more pixels than this (a 16k x 16k PNG is 768 MB of BGR).
constexpr double kMaxDecodedPixels = 64e6;

// libjpeg and libpng decode a cut-off file with a warning and fill the rest with gray, which
// would enroll a corrupt view. A complete JPEG ends with the EOI marker (FF D9), a complete PNG
// with its IEND chunk; allow a little trailing padding.
absl::Status CheckComplete(const std::string& bytes) {
  constexpr size_t kTail = 32;
  const std::string tail = bytes.substr(bytes.size() > kTail ? bytes.size() - kTail : 0);
  if (bytes.size() >= 2 && static_cast<uint8_t>(bytes[0]) == 0xFF &&
      static_cast<uint8_t>(bytes[1]) == 0xD8 && tail.find("\xFF\xD9") == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat(
        "JPEG data (", bytes.size(), " bytes) is truncated: no end-of-image marker"));
  }
  if (bytes.size() >= 8 && bytes.compare(1, 3, "PNG") == 0 &&
      tail.find("IEND") == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("PNG data (", bytes.size(), " bytes) is truncated: no IEND chunk"));
  }
  return absl::OkStatus();
}

}  // namespace

std::vector<cv::Point2f> KeypointPositions(const ImageFeatures& features) {
  std::vector<cv::Point2f> points;
  points.reserve(features.keypoints.size());
  for (const cv::KeyPoint& kp : features.keypoints) points.push_back(kp.pt);
  return points;
}

absl::StatusOr<cv::Mat> DecodeImage(const std::string& bytes) {
  if (bytes.empty()) return absl::InvalidArgumentError("image data is empty: send JPEG or PNG bytes");
  if (absl::Status s = CheckComplete(bytes); !s.ok()) return s;
  // The size is checked on the header, before the decoder allocates what the header claims.
  const std::optional<ImageHeader> header = ReadImageHeader(bytes);
  if (!header.has_value()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image data (", bytes.size(), " bytes) is not a JPEG or PNG image (no readable header)"));
  }
  if (static_cast<double>(header->width) * header->height > kMaxDecodedPixels) {
    return absl::InvalidArgumentError(absl::StrCat("image is ", header->width, "x",
                                                   header->height, ": more than 64 megapixels"));
  }
  cv::Mat image;
  try {
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8U,
                         const_cast<char*>(bytes.data()));
    image = cv::imdecode(buffer, cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("image could not be decoded: ", e.what()));
  }
  if (image.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image data (", bytes.size(), " bytes) is not a decodable JPEG or PNG image"));
  }
  if (image.cols < kMinImageSide || image.rows < kMinImageSide) {
    return absl::InvalidArgumentError(absl::StrCat("image is ", image.cols, "x", image.rows,
                                                   ": at least ", kMinImageSide, "x",
                                                   kMinImageSide, " pixels are needed"));
  }
  return image;  // its size was checked on the header
}

cv::Size WorkingSize(cv::Size image, const FeatureOptions& options) {
  if (!options.keep_aspect || image.width <= 0 || image.height <= 0) {
    return cv::Size(options.work_width, options.work_height);
  }
  const double scale = std::min(options.work_width / static_cast<double>(image.width),
                                options.work_height / static_cast<double>(image.height));
  return cv::Size(std::max(1, static_cast<int>(std::lround(image.width * scale))),
                  std::max(1, static_cast<int>(std::lround(image.height * scale))));
}

cv::Mat ToWorkingResolution(const cv::Mat& bgr, const FeatureOptions& options) {
  const cv::Size size = WorkingSize(bgr.size(), options);
  if (bgr.size() == size) return bgr;
  cv::Mat resized;
  const bool shrinking = bgr.cols > size.width;
  cv::resize(bgr, resized, size, 0, 0, shrinking ? cv::INTER_AREA : cv::INTER_LINEAR);
  return resized;
}

void ToRootSift(cv::Mat* descriptors) {
  // sqrt(d / |d|_1) has unit L2 norm, so no entry exceeds 1 and typical ones are 0.05-0.4;
  // 512 keeps them apart in 8 bits and saturates only the rare entries above 0.5.
  constexpr double kScale = 512.0;
  // kScale * sqrt(d) / sqrt(|d|_1): one square root per row and a table of the 256 others, the
  // same bytes as kScale * sqrt(d / |d|_1) for every value and every sum a row can have (checked
  // exhaustively, issue 34), at a fraction of the cost (it ran on every dense descriptor).
  static const std::array<double, 256> kRoots = [] {
    std::array<double, 256> roots{};
    for (int v = 0; v < 256; ++v) roots[v] = std::sqrt(static_cast<double>(v));
    return roots;
  }();
  for (int r = 0; r < descriptors->rows; ++r) {
    uint8_t* row = descriptors->ptr<uint8_t>(r);
    int sum = 0;
    for (int c = 0; c < descriptors->cols; ++c) sum += row[c];
    if (sum <= 0) continue;
    const double scale = kScale / std::sqrt(static_cast<double>(sum));
    for (int c = 0; c < descriptors->cols; ++c) {
      row[c] = cv::saturate_cast<uint8_t>(scale * kRoots[row[c]]);
    }
  }
}

absl::StatusOr<ImageFeatures> ExtractSift(const cv::Mat& working_bgr,
                                          const FeatureOptions& options) {
  ImageFeatures features;
  features.width = working_bgr.cols;
  features.height = working_bgr.rows;
  try {
    cv::Mat gray;
    cv::cvtColor(working_bgr, gray, cv::COLOR_BGR2GRAY);
    // nfeatures = 0 keeps all; nOctaveLayers = 3 -> 6 Gaussian images per octave (the paper's).
    auto sift = cv::SIFT::create(options.max_keypoints, 3, 0.04, 10, 1.6, CV_8U);
    sift->detectAndCompute(gray, cv::noArray(), features.keypoints, features.descriptors);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("SIFT extraction failed: ", e.what()));
  }
  if (features.descriptors.empty()) {
    features.descriptors = cv::Mat(0, kDescriptorSize, CV_8U);
  } else if (options.root_sift) {
    ToRootSift(&features.descriptors);
  }
  return features;
}

absl::StatusOr<ImageFeatures> ExtractFeatures(const std::string& encoded,
                                              const FeatureOptions& options,
                                              ExtractionTimings* timings) {
  ExtractionTimings local;
  auto start = Clock::now();
  absl::StatusOr<cv::Mat> image = DecodeImage(encoded);
  if (!image.ok()) return image.status();
  const cv::Mat working = ToWorkingResolution(*image, options);
  local.decode_ms = MsSince(start);

  // The dense descriptors on a thread of their own, beside SIFT: they cost about as much, and
  // a query waits for both (on a busy server the threads just share the cores).
  // (std::async: its future waits for the thread whichever way this function returns.)
  cv::Mat working_gray;
  std::future<cv::Mat> dense;
  if (options.global_descriptor) {
    dense = std::async(std::launch::async, [&] {
      const auto dense_start = Clock::now();
      cv::cvtColor(working, working_gray, cv::COLOR_BGR2GRAY);
      cv::Mat out = DenseRootSift(working_gray);
      local.dense_ms = MsSince(dense_start);
      return out;
    });
  }
  start = Clock::now();
  absl::StatusOr<ImageFeatures> features = ExtractSift(working, options);
  local.extraction_ms = MsSince(start);
  cv::Mat dense_descriptors;
  if (dense.valid()) {
    try {
      dense_descriptors = dense.get();
    } catch (const cv::Exception& e) {
      return absl::InternalError(absl::StrCat("dense SIFT extraction failed: ", e.what()));
    }
  }
  if (!features.ok()) return features.status();

  start = Clock::now();
  features->hue_hist = HueHistogram(working, options.hue_bins);
  local.histogram_ms = MsSince(start);
  features->working_gray = std::move(working_gray);
  features->dense = std::move(dense_descriptors);
  if (timings != nullptr) *timings = local;
  return features;
}

}  // namespace waymark::crossing
