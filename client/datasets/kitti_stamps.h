#ifndef WAYMARK_CLIENT_DATASETS_KITTI_STAMPS_H_
#define WAYMARK_CLIENT_DATASETS_KITTI_STAMPS_H_

// Time stamps of KITTI odometry data that carries none. poses.txt has no stamps, and a sequence
// may come without times.txt; then frame (and pose) i is at i * 0.1 s, the camera's 10 Hz. The
// image sequence reader (what `vo run` streams and stamps its trajectory with) and the pose-file
// reader (what `eval ate` compares against) both use this one rule, so that a `vo run` trajectory
// matches its sequence's poses.txt. A times.txt, where there is one, overrides it.

#include <cstddef>
#include <vector>

namespace waymark::cli {

// KITTI's camera period (s): the sensors run at 10 Hz.
inline constexpr double kKittiFramePeriod = 0.1;

// The stamp (s) of frame `index` of a KITTI sequence without times.txt.
inline double DefaultKittiStamp(size_t index) {
  return kKittiFramePeriod * static_cast<double>(index);
}

// The stamps of frames 0 .. count - 1.
inline std::vector<double> DefaultKittiStamps(size_t count) {
  std::vector<double> stamps;
  stamps.reserve(count);
  for (size_t i = 0; i < count; ++i) stamps.push_back(DefaultKittiStamp(i));
  return stamps;
}

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_KITTI_STAMPS_H_
