#ifndef WAYMARK_CLIENT_DATASETS_ROS_MAP_H_
#define WAYMARK_CLIENT_DATASETS_ROS_MAP_H_

// Occupancy grids as ROS map_server map files: map.pgm (the picture) + map.yaml (resolution,
// origin, thresholds), the pair `map_saver` writes and `map_server` / nav2 load.
//
// The grid (v1::OccupancyGrid, nav_msgs convention) is row-major from its lower-left cell; a PGM
// is row-major from its top row, so rows are flipped both ways: the grid's highest row (largest
// y) is PGM row 0. Cells are written in map_saver's trinary shades (occupied >= 65 black 0, free
// 0..19 white 254, anything else unknown grey 205), with occupied_thresh 0.65 and free_thresh
// 0.196, so a grid of -1 / 0 / 100 cells reads back unchanged and other values are quantised to
// those three. Reading follows map_server: p = (255 - pixel) / 255 (pixel / 255 with negate),
// occupied (100) if p > occupied_thresh, free (0) if p < free_thresh, else unknown (-1) in
// trinary mode or in proportion in scale mode; raw mode takes the pixel as the cell (0..100; any
// other value unknown).

#include <cstdint>
#include <filesystem>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/pgm_image.h"
#include "client/datasets/ros_map_yaml.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

inline constexpr char kRosMapYaml[] = "map.yaml";
inline constexpr char kRosMapPgm[] = "map.pgm";

// map_saver's shade of a cell: 0 occupied, 254 free, 205 unknown.
uint8_t PixelOfCell(int8_t cell);
// map_server's cell of a pixel under `metadata`'s negate, thresholds and mode.
int8_t CellOfPixel(uint8_t pixel, const RosMapMetadata& metadata);

// The grid as a PGM picture (top row = highest y). INVALID_ARGUMENT for a grid without cells, one
// whose cell count is not width x height, or a resolution that is not positive.
absl::StatusOr<GrayImage> GridImage(const v1::OccupancyGrid& grid);

// Writes DIR/map.pgm and DIR/map.yaml (DIR is created); returns them in that order. Errors:
// GridImage's, PERMISSION_DENIED when a file cannot be written.
absl::StatusOr<std::vector<std::filesystem::path>> WriteRosMap(const v1::OccupancyGrid& grid,
                                                               const std::filesystem::path& dir);

// Reads a map.yaml and the image it names (relative to the YAML's folder). Errors name the file
// and the problem: NOT_FOUND for a missing file, INVALID_ARGUMENT for ParseRosMapYaml's and
// ParsePgm's errors and for an origin yaw other than 0 (the grid is axis-aligned).
absl::StatusOr<v1::OccupancyGrid> ReadRosMap(const std::filesystem::path& yaml_path);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_ROS_MAP_H_
