#ifndef WAYMARK_CLIENT_RENDER_SLAM_OUTPUT_H_
#define WAYMARK_CLIENT_RENDER_SLAM_OUTPUT_H_

// What the slam commands write: the map pictures from a SegmentMap and a Trajectory, the
// trajectory in TUM format, and the occupancy grid as ROS map files and a picture.

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/render/map_render.h"
#include "client/datasets/tum_trajectory.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// Segment endpoints: frame origin + left/right along the frame's x axis.
SceneSegment SegmentEndpoints(const v1::MapSegment& segment);
std::vector<StampedPose> PosesOf(const v1::Trajectory& trajectory);

// The trajectory as the map pictures draw it: a thin green line with start and end markers.
ScenePolyline TrajectoryPolyline(const v1::Trajectory& trajectory);

// Segments coloured by endpoint type, the trajectory as a thin line with start and end markers
// and its last pose as the current pose (an arrow along its heading), and (when not empty) a
// reference path such as the raw odometry in grey, with its own start and end markers.
MapScene SlamScene(const v1::SegmentMap& map, const v1::Trajectory& trajectory,
                   const std::string& title, const std::vector<Vec2>& reference = {},
                   const std::string& reference_label = "raw odometry");

// DIR/trajectory.txt, DIR/map.svg, DIR/map.png (DIR is created).
absl::Status WriteSlamFiles(const std::filesystem::path& dir, const v1::SegmentMap& map,
                            const v1::Trajectory& trajectory, const std::string& title,
                            const std::vector<Vec2>& reference = {});

// Where the --out of a slam command points. A path ending in .svg or .png (any case) is that one
// picture of the map, so `--out map.svg` writes map.svg rather than a folder named map.svg;
// anything else is a folder that gets every output.
struct SlamOutTarget {
  enum class Kind { kFolder, kSvg, kPng };
  Kind kind = Kind::kFolder;
  std::filesystem::path path;

  bool is_folder() const { return kind == Kind::kFolder; }
};
SlamOutTarget SlamOutTargetOf(const std::filesystem::path& out);

// A folder gets WriteSlamFiles' three files; a picture only itself (its folder is created).
// Returns the files written, in the order written.
absl::StatusOr<std::vector<std::filesystem::path>> WriteSlamOutputs(
    const SlamOutTarget& target, const v1::SegmentMap& map, const v1::Trajectory& trajectory,
    const std::string& title, const std::vector<Vec2>& reference = {});

// DIR/map.pgm and DIR/map.yaml (ROS map_server files, datasets/ros_map.h) and DIR/occupancy.png
// (the grid with the trajectory on it and, when given, the map's self-check: DrawMapSelfCheck;
// DIR is created). Returns the files in that order.
absl::StatusOr<std::vector<std::filesystem::path>> WriteGridFiles(
    const std::filesystem::path& dir, const v1::OccupancyGrid& grid,
    const v1::Trajectory& trajectory, const v1::MapSelfCheck* self_check = nullptr);

// "out/aces/trajectory.txt, map.svg, map.png": the first path in full, the next ones by name when
// they share its folder.
std::string DescribeWritten(const std::vector<std::filesystem::path>& files);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_SLAM_OUTPUT_H_
