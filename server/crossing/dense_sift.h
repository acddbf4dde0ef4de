#ifndef WAYMARK_SERVER_CROSSING_DENSE_SIFT_H_
#define WAYMARK_SERVER_CROSSING_DENSE_SIFT_H_

// Dense SIFT in the manner of VLFeat's vl_dsift with a flat window (the descriptor DenseVLAD,
// Torii et al. 2015, aggregates): 4 x 4 cells of 8 orientation bins on a regular grid at several
// cell sizes, upright. Computed from per-orientation gradient images smoothed once per cell size,
// so each descriptor costs 128 look-ups instead of a window of samples: a few milliseconds per
// frame where OpenCV's SIFT::compute on the same grid takes hundreds. For the global descriptor
// (vlad.h), not for geometric matching.

#include <vector>

#include <opencv2/core.hpp>

namespace waymark::crossing {

struct DenseSiftOptions {
  int step = 6;                       // grid spacing, pixels at working resolution
  // Pixels per spatial cell (a descriptor is 4 cells wide). Chosen with waymark-vpr-eval's
  // global-descriptor report on the corridor and the triplets (docs/results.md).
  std::vector<int> cell_sizes = {6, 12, 18};
};

// N x 128 CV_8U RootSIFT descriptors (ToRootSift of SIFT-normalised values) of a BGR or grey
// image, every grid point of every cell size whose descriptor lies inside the image. Empty for an
// image smaller than the smallest descriptor.
cv::Mat DenseRootSift(const cv::Mat& image, const DenseSiftOptions& options = {});

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_DENSE_SIFT_H_
