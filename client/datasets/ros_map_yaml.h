#ifndef WAYMARK_CLIENT_DATASETS_ROS_MAP_YAML_H_
#define WAYMARK_CLIENT_DATASETS_ROS_MAP_YAML_H_

// The YAML half of a ROS map_server map (map.yaml): where the image is, its resolution and
// origin, and how its pixels become occupancy. Only the flat `key: value` form map_server and
// map_saver use is read (with '#' comments, quoted strings and the origin as a flow list
// [x, y, yaw]); that is every map file these tools write, and it needs no YAML library.

#include <string>

#include "absl/status/statusor.h"

namespace waymark::cli {

// How pixels become occupancy (map_server's `mode`).
enum class RosMapMode {
  kTrinary,  // occupied, free or unknown (the default)
  kScale,    // between the thresholds: occupancy in proportion
  kRaw,      // the pixel value is the cell value (0..100; 255 unknown)
};
const char* RosMapModeName(RosMapMode mode);  // "trinary", "scale", "raw"

struct RosMapMetadata {
  std::string image;         // as written: relative to the YAML file's folder unless absolute
  double resolution = 0.05;  // m per pixel
  double origin_x = 0;       // m, the lower-left pixel's corner
  double origin_y = 0;
  double origin_yaw = 0;  // rad
  bool negate = false;    // white is occupied
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
  RosMapMode mode = RosMapMode::kTrinary;
};

// The metadata in `text` (the contents of the file `name`, which the errors name, with the line
// for a bad value): INVALID_ARGUMENT for a line that is not `key: value`, a duplicate key, a
// missing key (image, resolution, origin, negate, occupied_thresh, free_thresh; mode is
// optional), a bad number, a resolution that is not positive, thresholds outside [0, 1] or with
// free_thresh not below occupied_thresh, an unknown mode. Keys map_server ignores are ignored.
absl::StatusOr<RosMapMetadata> ParseRosMapYaml(const std::string& text, const std::string& name);

// The file map_saver would write for `metadata`.
std::string FormatRosMapYaml(const RosMapMetadata& metadata);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_ROS_MAP_YAML_H_
