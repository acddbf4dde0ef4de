#include "client/render/occupancy_picture.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "client/datasets/ros_map.h"

namespace waymark::cli {

int OccupancyPictureScale(const v1::OccupancyGrid& grid, const OccupancyPictureOptions& options) {
  const int longer = static_cast<int>(std::max(grid.width(), grid.height()));
  if (longer <= 0 || options.min_size_px <= longer) return 1;
  return (options.min_size_px + longer - 1) / longer;  // ceil
}

absl::StatusOr<cv::Mat> OccupancyPicture(const v1::OccupancyGrid& grid,
                                         const std::vector<ScenePolyline>& paths,
                                         const OccupancyPictureOptions& options) {
  absl::StatusOr<GrayImage> image = GridImage(grid);
  if (!image.ok()) return image.status();
  const cv::Mat gray(image->height, image->width, CV_8UC1, image->pixels.data());
  const int scale = OccupancyPictureScale(grid, options);
  cv::Mat scaled;
  cv::resize(gray, scaled, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::Mat picture;
  cv::cvtColor(scaled, picture, cv::COLOR_GRAY2BGR);

  // World metres to picture pixels: x from the origin rightwards, y from the bottom edge up.
  const double pixels_per_metre = scale / grid.resolution();
  const double bottom = static_cast<double>(picture.rows);
  std::vector<DrawItem> items;
  for (const ScenePolyline& path : paths) {
    std::vector<Vec2> points;
    points.reserve(path.points.size());
    for (const Vec2& p : path.points) {
      points.push_back({(p.x - grid.origin().x()) * pixels_per_metre,
                        bottom - (p.y - grid.origin().y()) * pixels_per_metre});
    }
    const std::vector<DrawItem> drawn = PathItems(points, path.color, path.width_px);
    items.insert(items.end(), drawn.begin(), drawn.end());
  }
  DrawItemsOn(items, picture);
  return picture;
}

absl::Status WriteOccupancyPicture(const std::filesystem::path& path, const v1::OccupancyGrid& grid,
                                   const std::vector<ScenePolyline>& paths,
                                   const OccupancyPictureOptions& options) {
  absl::StatusOr<cv::Mat> picture = OccupancyPicture(grid, paths, options);
  if (!picture.ok()) return picture.status();
  return WritePngImage(*picture, path);
}

}  // namespace waymark::cli
