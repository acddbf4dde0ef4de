#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_STATIC_TEST_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_STATIC_TEST_H_

// eq 17: a matched feature is static when the position the camera motion predicts for it is
// within d pixels of where it was found, and its descriptor distance is below delta / 2. With
// depth the prediction is the reprojection of the reference point; without depth only the
// epipolar line is known, so the distance is to that line (a point moving along its epipolar line
// is not caught without depth: a limit of monocular geometry).

#include <vector>

#include "server/visual_slam/geometry/correspondence.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

struct StaticTestOptions {
  double distance_px = 3;  // d
  int max_hamming = 32;    // delta / 2
  double focal_px = 500;   // normalized errors are multiplied by this
};

// Distance (pixels) between the predicted and the found position of correspondence `c` under
// `motion`: with reference_point, |project(R X + t) - current| (+inf behind the camera); without,
// the distance of `current` to the epipolar line of `reference` under E = t^ R, or, when |t| is
// below 1e-9 (no translation: no epipolar geometry), to the rotation-only prediction R * reference.
double PredictionDistancePx(const Correspondence& c, const Motion& motion, double focal_px);

// Per correspondence (same order): static iff PredictionDistancePx <= distance_px and
// hamming < max_hamming.
std::vector<bool> StaticTest(const std::vector<Correspondence>& c, const Motion& motion,
                             const StaticTestOptions& options);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_STATIC_TEST_H_
