#include "client/datasets/ros_map.h"

#include <fmt/format.h>

#include <cmath>
#include <system_error>

#include "client/common/read_file.h"
#include "client/common/write_file.h"

namespace waymark::cli {
namespace {

constexpr int8_t kUnknown = -1;
constexpr int8_t kFree = 0;
constexpr int8_t kOccupied = 100;
// map_saver's trinary shades and the cell values it splits at. free <= 19 is the same split as
// free_thresh 0.196 on reading (p = cell / 100 < 0.196), so the YAML describes what was written.
constexpr uint8_t kOccupiedPixel = 0;
constexpr uint8_t kFreePixel = 254;
constexpr uint8_t kUnknownPixel = 205;
constexpr int kOccupiedFrom = 65;
constexpr int kFreeUpTo = 19;

// The YAML map_saver writes next to a trinary image.
RosMapMetadata SavedMetadata(const v1::OccupancyGrid& grid) {
  RosMapMetadata metadata;
  metadata.image = kRosMapPgm;
  metadata.resolution = grid.resolution();
  metadata.origin_x = grid.origin().x();
  metadata.origin_y = grid.origin().y();
  metadata.origin_yaw = grid.origin().theta();
  metadata.negate = false;
  metadata.occupied_thresh = 0.65;
  metadata.free_thresh = 0.196;
  metadata.mode = RosMapMode::kTrinary;
  return metadata;
}

}  // namespace

uint8_t PixelOfCell(int8_t cell) {
  if (cell >= kOccupiedFrom) return kOccupiedPixel;
  if (cell >= 0 && cell <= kFreeUpTo) return kFreePixel;
  return kUnknownPixel;
}

int8_t CellOfPixel(uint8_t pixel, const RosMapMetadata& metadata) {
  if (metadata.mode == RosMapMode::kRaw) {
    return pixel <= kOccupied ? static_cast<int8_t>(pixel) : kUnknown;
  }
  const double p = metadata.negate ? pixel / 255.0 : (255.0 - pixel) / 255.0;
  if (p > metadata.occupied_thresh) return kOccupied;
  if (p < metadata.free_thresh) return kFree;
  if (metadata.mode == RosMapMode::kTrinary) return kUnknown;
  // Scale: in proportion between the thresholds (nav2's rule).
  const double fraction =
      (p - metadata.free_thresh) / (metadata.occupied_thresh - metadata.free_thresh);
  return static_cast<int8_t>(std::lround(fraction * kOccupied));
}

absl::StatusOr<GrayImage> GridImage(const v1::OccupancyGrid& grid) {
  const int64_t cells = static_cast<int64_t>(grid.width()) * grid.height();
  if (cells == 0) {
    return absl::InvalidArgumentError(
        fmt::format("the grid has no cells ({} x {})", grid.width(), grid.height()));
  }
  if (static_cast<int64_t>(grid.cells().size()) != cells) {
    return absl::InvalidArgumentError(fmt::format("the grid has {} cells, not {} x {} = {}",
                                                  grid.cells().size(), grid.width(), grid.height(),
                                                  cells));
  }
  if (!(grid.resolution() > 0) || !std::isfinite(grid.resolution())) {
    return absl::InvalidArgumentError(
        fmt::format("the grid's resolution {} m is not positive", grid.resolution()));
  }
  GrayImage image;
  image.width = static_cast<int>(grid.width());
  image.height = static_cast<int>(grid.height());
  image.pixels.resize(static_cast<size_t>(cells));
  for (int row = 0; row < image.height; ++row) {
    const int grid_row = image.height - 1 - row;  // PGM rows run down, grid rows up
    for (int column = 0; column < image.width; ++column) {
      const auto cell =
          static_cast<int8_t>(grid.cells()[static_cast<size_t>(grid_row) * image.width + column]);
      image.pixels[static_cast<size_t>(row) * image.width + column] = PixelOfCell(cell);
    }
  }
  return image;
}

absl::StatusOr<std::vector<std::filesystem::path>> WriteRosMap(const v1::OccupancyGrid& grid,
                                                               const std::filesystem::path& dir) {
  absl::StatusOr<GrayImage> image = GridImage(grid);
  if (!image.ok()) return image.status();
  std::error_code ec;
  if (!dir.empty()) std::filesystem::create_directories(dir, ec);
  if (ec) {
    return absl::PermissionDeniedError("cannot create '" + dir.string() + "': " + ec.message());
  }
  const std::filesystem::path pgm = dir / kRosMapPgm;
  const std::filesystem::path yaml = dir / kRosMapYaml;
  const std::string comment =
      fmt::format("CREATOR: waymark {:.3f} m/pix, session {} revision {}", grid.resolution(),
                  grid.session_id(), grid.map_revision());
  if (absl::Status s = WriteFileBytes(pgm, EncodePgm(*image, comment)); !s.ok()) return s;
  if (absl::Status s = WriteFileBytes(yaml, FormatRosMapYaml(SavedMetadata(grid))); !s.ok()) {
    return s;
  }
  return std::vector<std::filesystem::path>{pgm, yaml};
}

absl::StatusOr<v1::OccupancyGrid> ReadRosMap(const std::filesystem::path& yaml_path) {
  absl::StatusOr<std::string> yaml = ReadFileBytes(yaml_path);
  if (!yaml.ok()) return yaml.status();
  absl::StatusOr<RosMapMetadata> metadata = ParseRosMapYaml(*yaml, yaml_path.string());
  if (!metadata.ok()) return metadata.status();
  if (metadata->origin_yaw != 0) {
    return absl::InvalidArgumentError(
        fmt::format("{}: origin yaw {} is not supported: Waymark grids are axis-aligned (yaw 0)",
                    yaml_path.string(), metadata->origin_yaw));
  }
  const std::filesystem::path image_path = yaml_path.parent_path() / metadata->image;
  absl::StatusOr<std::string> bytes = ReadFileBytes(image_path);
  if (!bytes.ok()) {
    return absl::Status(bytes.status().code(),
                        fmt::format("{} (the image of {})", std::string(bytes.status().message()),
                                    yaml_path.string()));
  }
  absl::StatusOr<GrayImage> image = ParsePgm(*bytes, image_path.string());
  if (!image.ok()) return image.status();

  v1::OccupancyGrid grid;
  grid.set_resolution(metadata->resolution);
  grid.mutable_origin()->set_x(metadata->origin_x);
  grid.mutable_origin()->set_y(metadata->origin_y);
  grid.set_width(static_cast<uint32_t>(image->width));
  grid.set_height(static_cast<uint32_t>(image->height));
  std::string cells(image->pixels.size(), '\0');
  for (int row = 0; row < image->height; ++row) {
    const int grid_row = image->height - 1 - row;
    for (int column = 0; column < image->width; ++column) {
      cells[static_cast<size_t>(grid_row) * image->width + column] =
          static_cast<char>(CellOfPixel(image->At(column, row), *metadata));
    }
  }
  grid.set_cells(std::move(cells));
  return grid;
}

}  // namespace waymark::cli
