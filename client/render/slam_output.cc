#include "client/render/slam_output.h"

#include <cctype>
#include <cmath>
#include <system_error>

#include "client/datasets/ros_map.h"
#include "client/render/occupancy_picture.h"

namespace waymark::cli {

SceneSegment SegmentEndpoints(const v1::MapSegment& segment) {
  const double c = std::cos(segment.frame().theta()), s = std::sin(segment.frame().theta());
  const double x = segment.frame().x(), y = segment.frame().y();
  SceneSegment out;
  out.a = {x + c * segment.left(), y + s * segment.left()};
  out.b = {x + c * segment.right(), y + s * segment.right()};
  out.a_real = segment.left_type() == v1::MapSegment::REAL;
  out.b_real = segment.right_type() == v1::MapSegment::REAL;
  return out;
}

std::vector<StampedPose> PosesOf(const v1::Trajectory& trajectory) {
  std::vector<StampedPose> poses;
  poses.reserve(trajectory.poses_size());
  for (const v1::TrajectoryPose& p : trajectory.poses()) {
    poses.push_back({p.stamp(), {p.pose().x(), p.pose().y(), p.pose().theta()}});
  }
  return poses;
}

ScenePolyline TrajectoryPolyline(const v1::Trajectory& trajectory) {
  ScenePolyline path;
  path.color = {30, 150, 60};
  path.width_px = 1.0;
  path.label = "trajectory";
  path.mark_ends = true;
  for (const v1::TrajectoryPose& p : trajectory.poses()) {
    path.points.push_back({p.pose().x(), p.pose().y()});
  }
  return path;
}

MapScene SlamScene(const v1::SegmentMap& map, const v1::Trajectory& trajectory,
                   const std::string& title, const std::vector<Vec2>& reference,
                   const std::string& reference_label) {
  MapScene scene;
  scene.title = title;
  for (const v1::MapSegment& segment : map.segments()) {
    scene.segments.push_back(SegmentEndpoints(segment));
  }
  ScenePolyline path = TrajectoryPolyline(trajectory);
  if (trajectory.poses_size() > 0) {
    const v1::Pose2D& last = trajectory.poses(trajectory.poses_size() - 1).pose();
    scene.current_pose = ScenePose{{last.x(), last.y()}, last.theta(), path.color, "current pose"};
  }
  scene.polylines.push_back(std::move(path));
  if (!reference.empty()) {
    ScenePolyline ref;
    ref.color = {170, 170, 170};
    ref.width_px = 1.0;
    ref.label = reference_label;
    ref.points = reference;
    ref.mark_ends = true;
    scene.references.push_back(std::move(ref));
  }
  return scene;
}

namespace {

absl::Status CreateFolder(const std::filesystem::path& dir) {
  if (dir.empty()) return absl::OkStatus();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    return absl::PermissionDeniedError("cannot create '" + dir.string() + "': " + ec.message());
  }
  return absl::OkStatus();
}

std::string Lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

SlamOutTarget SlamOutTargetOf(const std::filesystem::path& out) {
  const std::string extension = Lowercase(out.extension().string());
  SlamOutTarget target;
  target.path = out;
  if (extension == ".svg") target.kind = SlamOutTarget::Kind::kSvg;
  if (extension == ".png") target.kind = SlamOutTarget::Kind::kPng;
  return target;
}

absl::StatusOr<std::vector<std::filesystem::path>> WriteSlamOutputs(
    const SlamOutTarget& target, const v1::SegmentMap& map, const v1::Trajectory& trajectory,
    const std::string& title, const std::vector<Vec2>& reference) {
  if (target.is_folder()) {
    if (absl::Status s = WriteSlamFiles(target.path, map, trajectory, title, reference); !s.ok()) {
      return s;
    }
    return std::vector<std::filesystem::path>{target.path / "trajectory.txt",
                                              target.path / "map.svg", target.path / "map.png"};
  }
  if (absl::Status s = CreateFolder(target.path.parent_path()); !s.ok()) return s;
  const Drawing drawing = LayoutScene(SlamScene(map, trajectory, title, reference));
  if (absl::Status s = WriteDrawingFile(drawing, target.path); !s.ok()) return s;
  return std::vector<std::filesystem::path>{target.path};
}

absl::StatusOr<std::vector<std::filesystem::path>> WriteGridFiles(
    const std::filesystem::path& dir, const v1::OccupancyGrid& grid,
    const v1::Trajectory& trajectory, const v1::MapSelfCheck* self_check) {
  absl::StatusOr<std::vector<std::filesystem::path>> files = WriteRosMap(grid, dir);
  if (!files.ok()) return files.status();
  const std::filesystem::path path = dir / "occupancy.png";
  std::vector<ScenePolyline> paths;
  if (trajectory.poses_size() > 0) paths.push_back(TrajectoryPolyline(trajectory));
  absl::StatusOr<cv::Mat> picture = OccupancyPicture(grid, paths);
  if (!picture.ok()) return picture.status();
  if (self_check != nullptr) DrawMapSelfCheck(grid, *self_check, {}, &*picture);
  if (absl::Status s = WritePngImage(*picture, path); !s.ok()) return s;
  files->push_back(path);
  return files;
}

std::string DescribeWritten(const std::vector<std::filesystem::path>& files) {
  std::string text;
  for (size_t i = 0; i < files.size(); ++i) {
    if (i == 0) {
      text = files[i].string();
    } else {
      const bool same_folder = files[i].parent_path() == files[0].parent_path();
      text += ", " + (same_folder ? files[i].filename().string() : files[i].string());
    }
  }
  return text;
}

absl::Status WriteSlamFiles(const std::filesystem::path& dir, const v1::SegmentMap& map,
                            const v1::Trajectory& trajectory, const std::string& title,
                            const std::vector<Vec2>& reference) {
  if (absl::Status s = CreateFolder(dir); !s.ok()) return s;
  if (absl::Status s = WriteTumFile(dir / "trajectory.txt", PosesOf(trajectory)); !s.ok()) {
    return s;
  }
  return WriteMapPictures(SlamScene(map, trajectory, title, reference), dir / "map.svg",
                          dir / "map.png");
}

}  // namespace waymark::cli
