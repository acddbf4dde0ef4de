#include "server/service/live/live_messages.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/escaping.h"

namespace waymark::service::live {
namespace {

using nlohmann::json;

json Time(double stamp) {
  if (!std::isfinite(stamp) || stamp < 0) stamp = 0;
  double whole = std::floor(stamp);
  int64_t nsec = std::llround((stamp - whole) * 1e9);
  if (nsec >= 1000000000) {
    whole += 1;
    nsec -= 1000000000;
  }
  return {{"sec", static_cast<int64_t>(whole)}, {"nsec", nsec}};
}

json Pose2DJson(double x, double y, double theta) {
  return {{"position", {{"x", x}, {"y", y}, {"z", 0.0}}},
          {"orientation",
           {{"x", 0.0}, {"y", 0.0}, {"z", std::sin(theta / 2)}, {"w", std::cos(theta / 2)}}}};
}

json Pose3DJson(const v1::Pose3D& p) {
  return {{"position", {{"x", p.x()}, {"y", p.y()}, {"z", p.z()}}},
          {"orientation", {{"x", p.qx()}, {"y", p.qy()}, {"z", p.qz()}, {"w", p.qw()}}}};
}

json PoseOf(const v1::SlamUpdate& update) {
  if (update.has_pose3d()) return Pose3DJson(update.pose3d());
  return Pose2DJson(update.pose().x(), update.pose().y(), update.pose().theta());
}

// A message's fields as protobuf JSON (field names as in the .proto), or null.
json ProtoJson(const google::protobuf::Message& message) {
  std::string text;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  if (!google::protobuf::util::MessageToJsonString(message, &text, options).ok()) return nullptr;
  return json::parse(text, nullptr, false);
}

double Finite(double value) { return std::isfinite(value) ? value : 0.0; }

}  // namespace

uint64_t StampNanos(double stamp) {
  if (!std::isfinite(stamp) || stamp < 0 || stamp > 1.8e10) return 0;
  return static_cast<uint64_t>(std::llround(stamp * 1e9));
}

std::string PoseJson(const v1::SlamUpdate& update) {
  return json{{"timestamp", Time(update.stamp())}, {"frame_id", kMapFrame}, {"pose", PoseOf(update)}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string ScanJson(const ScanSample& scan, const v1::Pose2D& robot,
                     const v1::Pose2D& laser_pose) {
  const double c = std::cos(robot.theta()), s = std::sin(robot.theta());
  const double x = robot.x() + c * laser_pose.x() - s * laser_pose.y();
  const double y = robot.y() + s * laser_pose.x() + c * laser_pose.y();
  const double theta = robot.theta() + laser_pose.theta();
  json ranges = json::array();
  for (float r : scan.ranges) {
    const bool none = !std::isfinite(r) || r <= 0 ||
                      (scan.no_return_range > 0 && r >= scan.no_return_range);
    ranges.push_back(none ? 0.0 : static_cast<double>(r));
  }
  const double span =
      scan.ranges.empty() ? 0.0 : scan.angle_increment * static_cast<double>(scan.ranges.size() - 1);
  return json{{"timestamp", Time(scan.stamp)},
              {"frame_id", kMapFrame},
              {"pose", Pose2DJson(x, y, theta)},
              {"start_angle", scan.angle_min},
              {"end_angle", scan.angle_min + span},
              {"ranges", std::move(ranges)},
              {"intensities", json::array()}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string GridJson(const v1::OccupancyGrid& grid, double stamp) {
  return json{{"timestamp", Time(stamp)},
              {"frame_id", kMapFrame},
              {"pose", Pose2DJson(grid.origin().x(), grid.origin().y(), 0.0)},
              {"column_count", grid.width()},
              {"cell_size", {{"x", grid.resolution()}, {"y", grid.resolution()}}},
              {"row_stride", grid.width()},
              {"cell_stride", 1},
              {"fields", json::array({{{"name", "occupancy"}, {"offset", 0}, {"type", 2}}})},
              {"data", absl::Base64Escape(grid.cells())}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string TrajectoryJson(const v1::Trajectory& trajectory, double stamp, size_t max_poses) {
  const size_t n = static_cast<size_t>(trajectory.poses_size());
  const size_t step = (max_poses == 0 || n <= max_poses) ? 1 : (n + max_poses - 1) / max_poses;
  json poses = json::array();
  for (size_t i = 0; i < n; i += step) {
    const v1::TrajectoryPose& p = trajectory.poses(static_cast<int>(i));
    poses.push_back(p.has_pose3d() ? Pose3DJson(p.pose3d())
                                   : Pose2DJson(p.pose().x(), p.pose().y(), p.pose().theta()));
  }
  if (n > 0 && (n - 1) % step != 0) {
    const v1::TrajectoryPose& p = trajectory.poses(static_cast<int>(n - 1));
    poses.push_back(p.has_pose3d() ? Pose3DJson(p.pose3d())
                                   : Pose2DJson(p.pose().x(), p.pose().y(), p.pose().theta()));
  }
  return json{{"timestamp", Time(stamp)}, {"frame_id", kMapFrame}, {"poses", std::move(poses)}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string LoopClosuresJson(const v1::SlamUpdate& update, uint32_t previous) {
  const uint32_t count = update.loop_closures();
  return json{{"timestamp", Time(update.stamp())},
              {"loop_closures", count},
              {"new_closures", count >= previous ? count - previous : count},
              {"graph_revision", update.graph_revision()},
              {"scans_processed", update.scans_processed()},
              {"pose", PoseOf(update)}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string ConfidenceJson(const v1::SlamUpdate& update) {
  json out = {{"timestamp", Time(update.stamp())}};
  if (update.covariance_size() == 9) {
    json covariance = json::array();
    for (double v : update.covariance()) covariance.push_back(Finite(v));
    out["covariance"] = std::move(covariance);
    out["sigma_x"] = std::sqrt(std::max(0.0, Finite(update.covariance(0))));
    out["sigma_y"] = std::sqrt(std::max(0.0, Finite(update.covariance(4))));
    out["sigma_theta"] = std::sqrt(std::max(0.0, Finite(update.covariance(8))));
  }
  if (!update.has_pose3d()) {
    out["covariance_trace_mean"] = Finite(update.covariance_trace_mean());
    out["segments"] = update.segments();
    out["matched_segments"] = update.matched_segments();
    out["observed_segments"] = update.observed_segments();
  }
  if (update.has_localization()) out["localization"] = ProtoJson(update.localization());
  if (update.visual().has_quality()) out["tracking"] = ProtoJson(update.visual().quality());
  return out.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string VisualFrameJson(const v1::SlamUpdate& update) {
  const v1::VisualFrameInfo& info = update.visual();
  json boxes = json::array();
  for (const v1::BoundingBox& box : info.boxes()) boxes.push_back(ProtoJson(box));
  json counts = ProtoJson(info.counts());
  json quality = ProtoJson(info.quality());
  return json{{"timestamp", Time(update.stamp())},
              {"state", v1::VisualFrameInfo::TrackingState_Name(info.state())},
              {"keyframe", info.keyframe()},
              {"relocalized", info.relocalized()},
              {"counts", counts.is_object() ? counts : json::object()},
              {"quality", quality.is_object() ? quality : json::object()},
              {"boxes", std::move(boxes)},
              {"pose", PoseOf(update)}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string RecognitionJson(const std::string& database, const v1::RecognizeResponse& response,
                            double received_stamp) {
  v1::RecognizeResponse brief = response;
  brief.clear_candidates();
  json answer = ProtoJson(brief);
  return json{{"timestamp", Time(response.stamp() > 0 ? response.stamp() : received_stamp)},
              {"database", database},
              {"answer", answer.is_object() ? answer : json::object()}}
      .dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace waymark::service::live
