#ifndef WAYMARK_CLIENT_RENDER_OCCUPANCY_PICTURE_H_
#define WAYMARK_CLIENT_RENDER_OCCUPANCY_PICTURE_H_

// A picture of an occupancy grid (occupancy.png): map.pgm as a person looks at it, with the
// robot's path on it. Same orientation and shades as map.pgm (datasets/ros_map.h: top row =
// highest y; occupied black, free white, unknown grey), each cell an integer number of pixels so
// that a small grid is still big enough to see; paths as the map pictures draw trajectories.

#include <filesystem>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "client/render/map_render.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

struct OccupancyPictureOptions {
  // Cells are scaled up by the smallest integer that makes the longer side at least this many
  // pixels (a 40-cell grid would be a thumbnail otherwise); 0 = one pixel per cell.
  int min_size_px = 512;
};

// Pixels per cell for `grid` under `options` (at least 1).
int OccupancyPictureScale(const v1::OccupancyGrid& grid, const OccupancyPictureOptions& options);

// The 8-bit BGR picture; `paths` are in world metres (map frame), each drawn with its start and
// end markers. GridImage's errors for a grid that has no cells or not width x height of them.
absl::StatusOr<cv::Mat> OccupancyPicture(const v1::OccupancyGrid& grid,
                                         const std::vector<ScenePolyline>& paths = {},
                                         const OccupancyPictureOptions& options = {});

// The map's self-check (v1::MapSelfCheck; docs/laser-slam.md, "A map that checks itself") on a
// picture OccupancyPicture drew of `grid` with `options`: the contradicting cells filled red, the
// listed areas that contradict themselves outlined in orange, and the verdict's first words in the
// top-left corner (green when consistent, red when not). What a folded corridor looks like, where
// it is. Marks and caption grow with the picture (a cell is at least 2 pixels wide, and 2 per 1000
// pixels of the picture's longer side), so that a few cells on a large map are still seen.
void DrawMapSelfCheck(const v1::OccupancyGrid& grid, const v1::MapSelfCheck& check,
                      const OccupancyPictureOptions& options, cv::Mat* picture);

// A picture (8-bit BGR, as OccupancyPicture and DrawMapSelfCheck make it) shrunk to `width_px`
// pixels wide (area averaging; never enlarged) and written as an 8-bit palette PNG: 16 greys for
// the map and the exact colours of the self-check's marks and of paths (red, orange, green), each
// pixel the nearest of them. A thumbnail of a whole map for a page of many maps
// (docs/results.md's grid of every benchmark map): a 360-pixel map is 10-40 KB instead of the
// hundreds of an RGB picture. InvalidArgument for an empty picture or width_px < 16.
absl::Status WriteSmallPalettePicture(const cv::Mat& picture, int width_px,
                                      const std::filesystem::path& path);

// OccupancyPicture as a PNG file.
absl::Status WriteOccupancyPicture(const std::filesystem::path& path, const v1::OccupancyGrid& grid,
                                   const std::vector<ScenePolyline>& paths = {},
                                   const OccupancyPictureOptions& options = {});

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_OCCUPANCY_PICTURE_H_
