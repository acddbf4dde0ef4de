#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_BOX_SPLIT_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_BOX_SPLIT_H_

// eq 7: a feature p(u, v) is "potentially dynamic" when it lies inside any detector box of a
// movable class, else "not potentially dynamic".

#include <opencv2/core.hpp>
#include <vector>

#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

// Per pixel (same order): true when it lies inside any box, edges inclusive
// (x <= u <= x + w and y <= v <= y + h). Boxes with a negative or non-finite size contain nothing;
// non-finite pixels are inside nothing.
std::vector<bool> InsideAnyBox(const std::vector<cv::Point2f>& pixels,
                               const std::vector<Box>& boxes);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_BOX_SPLIT_H_
