#include "client/render/occupancy_picture.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

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

void DrawMapSelfCheck(const v1::OccupancyGrid& grid, const v1::MapSelfCheck& check,
                      const OccupancyPictureOptions& options, cv::Mat* picture) {
  const double pixels_per_metre = OccupancyPictureScale(grid, options) / grid.resolution();
  const auto to_pixel = [&](double x, double y) {
    return cv::Point(
        static_cast<int>(std::lround((x - grid.origin().x()) * pixels_per_metre)),
        static_cast<int>(std::lround(picture->rows - (y - grid.origin().y()) * pixels_per_metre)));
  };
  const cv::Scalar red(30, 30, 230), orange(0, 140, 255), green(60, 140, 30);  // BGR
  // Marks grow with the picture: a map of 200 m is a picture of 4000 pixels or more, looked at
  // whole on a screen a quarter that wide, where a 10 cm cell would vanish.
  const double enlarge = std::max(1.0, std::max(picture->cols, picture->rows) / 1000.0);
  const double half = std::max(check.resolution() / 2, enlarge / pixels_per_metre);
  for (int i = 0; i + 1 < check.contradicting_cells_size(); i += 2) {
    const double x = check.contradicting_cells(i), y = check.contradicting_cells(i + 1);
    cv::rectangle(*picture, to_pixel(x - half, y + half), to_pixel(x + half, y - half), red,
                  cv::FILLED);
  }
  const int outline = std::max(static_cast<int>(std::lround(1.2 * enlarge)),
                               std::max(2, static_cast<int>(pixels_per_metre * 0.05)));
  for (const v1::MapCheckArea& area : check.worst_areas()) {
    cv::rectangle(*picture, to_pixel(area.min_x(), area.min_y() + area.size()),
                  to_pixel(area.min_x() + area.size(), area.min_y()), orange, outline);
  }
  const std::string& verdict = check.verdict();
  cv::putText(*picture, verdict.substr(0, verdict.find(':')),
              cv::Point(static_cast<int>(8 * enlarge), static_cast<int>(24 * enlarge)),
              cv::FONT_HERSHEY_SIMPLEX, 0.7 * enlarge, check.consistent() ? green : red,
              static_cast<int>(std::lround(2 * enlarge)));
}

absl::Status WriteOccupancyPicture(const std::filesystem::path& path, const v1::OccupancyGrid& grid,
                                   const std::vector<ScenePolyline>& paths,
                                   const OccupancyPictureOptions& options) {
  absl::StatusOr<cv::Mat> picture = OccupancyPicture(grid, paths, options);
  if (!picture.ok()) return picture.status();
  return WritePngImage(*picture, path);
}

}  // namespace waymark::cli
