#include "client/render/occupancy_picture.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

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
  // A thumbnail (a few hundred pixels) gets thin outlines and a small caption, so that the map
  // under them is still seen.
  const int longer = std::max(picture->cols, picture->rows);
  const bool small = longer < 600;
  const int outline =
      small ? 1
            : std::max(static_cast<int>(std::lround(1.2 * enlarge)),
                       std::max(2, static_cast<int>(pixels_per_metre * 0.05)));
  for (const v1::MapCheckArea& area : check.worst_areas()) {
    cv::rectangle(*picture, to_pixel(area.min_x(), area.min_y() + area.size()),
                  to_pixel(area.min_x() + area.size(), area.min_y()), orange, outline);
  }
  const std::string& verdict = check.verdict();
  const double text = small ? std::max(0.35, 0.7 * longer / 600.0) / 0.7 : enlarge;
  cv::putText(*picture, verdict.substr(0, verdict.find(':')),
              cv::Point(static_cast<int>(std::lround(8 * text)),
                        static_cast<int>(std::lround(24 * text))),
              cv::FONT_HERSHEY_SIMPLEX, 0.7 * text, check.consistent() ? green : red,
              std::max(1, static_cast<int>(std::lround(2 * text))));
}

namespace {

// PNG chunks by hand (an indexed PNG, which OpenCV does not write): length, type, data, CRC.
void AppendU32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((v >> shift) & 0xff));
}

void AppendChunk(std::string& out, const char* type, const std::string& data) {
  AppendU32(out, static_cast<std::uint32_t>(data.size()));
  const std::string typed = std::string(type, 4) + data;
  out += typed;
  AppendU32(out, static_cast<std::uint32_t>(
                     crc32(0L, reinterpret_cast<const Bytef*>(typed.data()), typed.size())));
}

}  // namespace

absl::Status WriteSmallPalettePicture(const cv::Mat& picture, int width_px,
                                      const std::filesystem::path& path) {
  if (picture.empty() || picture.type() != CV_8UC3) {
    return absl::InvalidArgumentError("a small picture needs a non-empty 8-bit BGR picture");
  }
  if (width_px < 16) return absl::InvalidArgumentError("a small picture is at least 16 pixels wide");
  cv::Mat small = picture;
  if (picture.cols > width_px) {
    const int height =
        std::max(1, static_cast<int>(std::lround(double(picture.rows) * width_px / picture.cols)));
    cv::resize(picture, small, cv::Size(width_px, height), 0, 0, cv::INTER_AREA);
  }
  // The palette (RGB): 16 greys from black to map_saver's free white, then the marks' colours
  // (DrawMapSelfCheck's red, orange and green, the paths' green).
  std::vector<std::array<int, 3>> palette;
  for (int i = 0; i < 16; ++i) {
    const int g = i * 254 / 15;
    palette.push_back({g, g, g});
  }
  palette.push_back({230, 30, 30});    // contradicting cells, "contradicts itself"
  palette.push_back({255, 140, 0});    // areas that contradict themselves
  palette.push_back({30, 140, 60});    // "consistent"
  palette.push_back({30, 150, 60});    // the trajectory
  palette.push_back({205, 205, 205});  // map_saver's unknown grey, exactly
  std::string raw;  // filter byte 0 then one index per pixel, row by row
  raw.reserve(static_cast<size_t>(small.rows) * (small.cols + 1));
  for (int row = 0; row < small.rows; ++row) {
    raw.push_back(0);
    for (int column = 0; column < small.cols; ++column) {
      const cv::Vec3b bgr = small.at<cv::Vec3b>(row, column);
      int best = 0, best_distance = 1 << 30;
      for (size_t k = 0; k < palette.size(); ++k) {
        const int dr = palette[k][0] - bgr[2], dg = palette[k][1] - bgr[1],
                  db = palette[k][2] - bgr[0];
        const int distance = dr * dr + dg * dg + db * db;
        if (distance < best_distance) {
          best_distance = distance;
          best = static_cast<int>(k);
        }
      }
      raw.push_back(static_cast<char>(best));
    }
  }
  uLongf packed_size = compressBound(raw.size());
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size,
                reinterpret_cast<const Bytef*>(raw.data()), raw.size(), 9) != Z_OK) {
    return absl::InternalError("compressing '" + path.string() + "' failed");
  }
  packed.resize(packed_size);
  std::string header;
  AppendU32(header, static_cast<std::uint32_t>(small.cols));
  AppendU32(header, static_cast<std::uint32_t>(small.rows));
  header += std::string("\x08\x03\x00\x00\x00", 5);  // 8 bits, indexed, deflate, no filter, no interlace
  std::string colours;
  for (const auto& c : palette) {
    for (int v : c) colours.push_back(static_cast<char>(v));
  }
  std::string png("\x89PNG\r\n\x1a\n", 8);
  AppendChunk(png, "IHDR", header);
  AppendChunk(png, "PLTE", colours);
  AppendChunk(png, "IDAT", packed);
  AppendChunk(png, "IEND", "");
  std::ofstream file(path, std::ios::binary);
  file.write(png.data(), static_cast<std::streamsize>(png.size()));
  if (!file) return absl::PermissionDeniedError("cannot write '" + path.string() + "'");
  return absl::OkStatus();
}

absl::Status WriteOccupancyPicture(const std::filesystem::path& path, const v1::OccupancyGrid& grid,
                                   const std::vector<ScenePolyline>& paths,
                                   const OccupancyPictureOptions& options) {
  absl::StatusOr<cv::Mat> picture = OccupancyPicture(grid, paths, options);
  if (!picture.ok()) return picture.status();
  return WritePngImage(*picture, path);
}

}  // namespace waymark::cli
