#ifndef WAYMARK_TESTS_FUZZ_FUZZ_IMAGES_H_
#define WAYMARK_TESTS_FUZZ_FUZZ_IMAGES_H_

// Camera views for the seeds of the targets that decode images: crops of the simulator's
// generated panoramas (client/sim/sim_scene.h), made by code so that nothing of ../shared is copied
// into the repository. Small, so that decoding and extracting features from a mutated one stays
// around a millisecond; textured, so that SIFT and ORB find features in them.

#include <cstdint>
#include <opencv2/core.hpp>

#include "client/sim/sim_scene.h"

namespace waymark::fuzz {

inline constexpr int kViewWidth = 64;
inline constexpr int kViewHeight = 48;

// The view of scene `scene` (one generated panorama per number) towards `heading_deg`: a 60
// degree crop of a 1920 x 144 panorama shrunk 5 times, so that it holds many shapes (and SIFT
// finds the 10 keypoints an enrolled view needs at 64 x 48).
inline cv::Mat FuzzView(uint32_t scene, double heading_deg) {
  return adapters::CropView(adapters::MakePanorama(scene, 1920, 144), heading_deg, 60, kViewWidth,
                            kViewHeight);
}

// A depth image of the same size (16-bit, millimetres at the TUM scale of 5000 per metre): a
// ramp from 1 m on the left.
inline cv::Mat FuzzDepth() {
  cv::Mat depth(kViewHeight, kViewWidth, CV_16UC1);
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x)
      depth.at<uint16_t>(y, x) = static_cast<uint16_t>(5000 + 40 * x);
  }
  return depth;
}

}  // namespace waymark::fuzz

#endif  // WAYMARK_TESTS_FUZZ_FUZZ_IMAGES_H_
