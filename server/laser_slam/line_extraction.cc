#include "server/laser_slam/line_extraction.h"

namespace waymark::laser_slam {

// Placeholder until the extraction lands (issue 3, in progress).
absl::StatusOr<std::vector<ObservedSegment>> ExtractSegments(const LaserScan& scan,
                                                             const LineExtractionOptions& options) {
  if (absl::Status s = ValidateScanGeometry(scan.geometry); !s.ok()) return s;
  (void)options;
  return std::vector<ObservedSegment>{};
}

}  // namespace waymark::laser_slam
