#include "server/crossing/dense_sift.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "server/crossing/features.h"

namespace waymark::crossing {
namespace {

constexpr int kOrientations = 8;
constexpr int kCells = 4;  // per side
constexpr int kLength = kCells * kCells * kOrientations;
static_assert(kLength == kDescriptorSize);

// The buffers of one extraction, reused from one cell size to the next: the server allocates
// blocks of 256 KB and more with their own mapping (server/main.cc), so a fresh image per step
// cost a page fault per 4 KB touched, about as much as the arithmetic (issue 34).
struct Workspace {
  cv::Mat smooth, dx, dy, magnitude, angle;
  std::array<cv::Mat, kOrientations> channels;
};

// The gradient magnitude of `gray` split into kOrientations images by orientation (into
// ws->channels), each pixel's magnitude shared linearly between its two nearest orientation bins.
void OrientationChannels(const cv::Mat& gray, Workspace* ws) {
  cv::Sobel(gray, ws->dx, CV_32F, 1, 0, 1, 0.5);  // central differences
  cv::Sobel(gray, ws->dy, CV_32F, 0, 1, 1, 0.5);
  cv::cartToPolar(ws->dx, ws->dy, ws->magnitude, ws->angle);  // radians in [0, 2 pi)
  std::array<cv::Mat, kOrientations>& channels = ws->channels;
  for (cv::Mat& c : channels) {
    c.create(gray.size(), CV_32F);
    c.setTo(0);
  }
  const float to_bins = kOrientations / static_cast<float>(2 * CV_PI);
  std::array<float*, kOrientations> rows{};
  for (int y = 0; y < gray.rows; ++y) {
    const float* m = ws->magnitude.ptr<float>(y);
    const float* a = ws->angle.ptr<float>(y);
    for (int o = 0; o < kOrientations; ++o) rows[o] = channels[o].ptr<float>(y);
    for (int x = 0; x < gray.cols; ++x) {
      const float t = a[x] * to_bins;
      const int lower = static_cast<int>(t);
      const float upper_share = t - lower;
      rows[lower % kOrientations][x] += m[x] * (1 - upper_share);
      rows[(lower + 1) % kOrientations][x] += m[x] * upper_share;
    }
  }
}

// SIFT's normalisation: unit length, values clamped at 0.2, unit length again; then OpenCV's
// integer scale (x 512, saturated), so ToRootSift treats it as any SIFT descriptor.
void NormaliseInto(const float* raw, uchar* out) {
  double norm = 0;
  for (int k = 0; k < kLength; ++k) norm += raw[k] * raw[k];
  norm = std::sqrt(norm);
  std::array<float, kLength> v{};
  if (norm > 0) {
    double clamped_norm = 0;
    for (int k = 0; k < kLength; ++k) {
      v[k] = std::min(static_cast<float>(raw[k] / norm), 0.2f);
      clamped_norm += v[k] * v[k];
    }
    clamped_norm = std::sqrt(clamped_norm);
    for (int k = 0; k < kLength; ++k) v[k] = static_cast<float>(v[k] / clamped_norm);
  }
  for (int k = 0; k < kLength; ++k) out[k] = cv::saturate_cast<uchar>(v[k] * 512.0f);
}

}  // namespace

cv::Mat DenseRootSift(const cv::Mat& image, const DenseSiftOptions& options) {
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = image;
  }
  gray.convertTo(gray, CV_32F, 1.0 / 255.0);
  const int step = std::max(1, options.step);
  // Grid points per cell size whose descriptor lies inside the image.
  auto grid = [&](int cell, int extent) {
    const int half = kCells * cell / 2;
    return extent < 2 * half ? 0 : (extent - 2 * half) / step + 1;
  };
  int total = 0;
  for (int cell : options.cell_sizes) {
    if (cell >= 1) total += grid(cell, gray.cols) * grid(cell, gray.rows);
  }
  cv::Mat out(total, kLength, CV_8U);
  int row = 0;
  std::array<float, kLength> raw{};
  Workspace ws;
  const std::array<cv::Mat, kOrientations>& channels = ws.channels;
  for (int cell : options.cell_sizes) {
    if (cell < 1 || grid(cell, gray.cols) * grid(cell, gray.rows) == 0) continue;
    // vl_phow's pre-smoothing for the cell size (sigma = cell / 6), then the orientation images
    // integrated over each cell with a triangular window of half-width `cell` (a box twice).
    cv::GaussianBlur(gray, ws.smooth, cv::Size(), cell / 6.0);
    OrientationChannels(ws.smooth, &ws);
    for (cv::Mat& c : ws.channels) {
      cv::boxFilter(c, c, -1, cv::Size(cell, cell), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
      cv::boxFilter(c, c, -1, cv::Size(cell, cell), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    }
    const int half = kCells * cell / 2;
    for (int gy = 0; gy < grid(cell, gray.rows); ++gy) {
      const int y = half + gy * step;
      for (int gx = 0; gx < grid(cell, gray.cols); ++gx) {
        const int x = half + gx * step;
        for (int j = 0; j < kCells; ++j) {
          const int cy = std::min(gray.rows - 1, y - half + j * cell + cell / 2);
          for (int i = 0; i < kCells; ++i) {
            const int cx = std::min(gray.cols - 1, x - half + i * cell + cell / 2);
            float* bins = &raw[(j * kCells + i) * kOrientations];
            for (int o = 0; o < kOrientations; ++o) bins[o] = channels[o].ptr<float>(cy)[cx];
          }
        }
        NormaliseInto(raw.data(), out.ptr<uchar>(row++));
      }
    }
  }
  if (!out.empty()) ToRootSift(&out);
  return out;
}

}  // namespace waymark::crossing
