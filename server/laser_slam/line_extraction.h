#ifndef WAYMARK_SERVER_LASER_SLAM_LINE_EXTRACTION_H_
#define WAYMARK_SERVER_LASER_SLAM_LINE_EXTRACTION_H_

// Line segments from one 2-D laser scan (METHODS.md section 2, "Line extraction per scan").

#include <vector>

#include "absl/status/statusor.h"
#include "server/laser_slam/options.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// Segments in the laser frame, ordered by beam index. INVALID_ARGUMENT when the scan's range count
// disagrees with its geometry or the geometry is invalid. Non-finite, negative or zero ranges and
// ranges at or above geometry.no_return_range are no-returns.
absl::StatusOr<std::vector<ObservedSegment>> ExtractSegments(const LaserScan& scan,
                                                             const LineExtractionOptions& options);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_LINE_EXTRACTION_H_
