#include "server/service/live/live_schemas.h"

#include <nlohmann/json.hpp>

namespace waymark::service::live {
namespace {

using nlohmann::json;

json Number() { return {{"type", "number"}}; }
json Integer() { return {{"type", "integer"}}; }
json String() { return {{"type", "string"}}; }
json Boolean() { return {{"type", "boolean"}}; }
json ArrayOf(json items) { return {{"type", "array"}, {"items", std::move(items)}}; }

json Object(const char* title, json properties, json required = json::array()) {
  json out = {{"type", "object"}, {"properties", std::move(properties)}};
  if (title != nullptr) out["title"] = title;
  if (!required.empty()) out["required"] = std::move(required);
  return out;
}

json Time() {
  return Object("time",
                {{"sec", {{"type", "integer"}, {"minimum", 0}}},
                 {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}},
                {"sec", "nsec"});
}

json Vector3() {
  return Object("foxglove.Vector3", {{"x", Number()}, {"y", Number()}, {"z", Number()}},
                {"x", "y", "z"});
}

json Quaternion() {
  return Object("foxglove.Quaternion",
                {{"x", Number()}, {"y", Number()}, {"z", Number()}, {"w", Number()}},
                {"x", "y", "z", "w"});
}

json Pose() {
  return Object("foxglove.Pose", {{"position", Vector3()}, {"orientation", Quaternion()}},
                {"position", "orientation"});
}

ChannelSchema Make(const char* suffix, const char* name, json properties,
                   json required = json::array()) {
  json schema = Object(name, std::move(properties), std::move(required));
  return ChannelSchema{suffix, name, schema.dump()};
}

}  // namespace

const ChannelSchema& PoseSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("pose", "foxglove.PoseInFrame",
           {{"timestamp", Time()}, {"frame_id", String()}, {"pose", Pose()}},
           {"timestamp", "frame_id", "pose"}));
  return *kSchema;
}

const ChannelSchema& ScanSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("scan", "foxglove.LaserScan",
           {{"timestamp", Time()},
            {"frame_id", String()},
            {"pose", Pose()},
            {"start_angle", Number()},
            {"end_angle", Number()},
            {"ranges", ArrayOf(Number())},
            {"intensities", ArrayOf(Number())}},
           {"timestamp", "frame_id", "pose", "start_angle", "end_angle", "ranges",
            "intensities"}));
  return *kSchema;
}

namespace {

json PackedElementField() {
  json numeric_type = {{"title", "foxglove.NumericType"}, {"type", "integer"},
                       {"minimum", 0}, {"maximum", 8}};
  return Object("foxglove.PackedElementField",
                {{"name", String()},
                 {"offset", {{"type", "integer"}, {"minimum", 0}}},
                 {"type", numeric_type}},
                {"name", "offset", "type"});
}

}  // namespace

const ChannelSchema& GridSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("grid", "foxglove.Grid",
           {{"timestamp", Time()},
            {"frame_id", String()},
            {"pose", Pose()},
            {"column_count", {{"type", "integer"}, {"minimum", 0}}},
            {"cell_size", Object("foxglove.Vector2", {{"x", Number()}, {"y", Number()}},
                                 {"x", "y"})},
            {"row_stride", {{"type", "integer"}, {"minimum", 0}}},
            {"cell_stride", {{"type", "integer"}, {"minimum", 0}}},
            {"fields", ArrayOf(PackedElementField())},
            {"data", {{"type", "string"}, {"contentEncoding", "base64"}}}},
           {"timestamp", "frame_id", "pose", "column_count", "cell_size", "row_stride",
            "cell_stride", "fields", "data"}));
  return *kSchema;
}

const ChannelSchema& TrajectorySchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("trajectory", "foxglove.PosesInFrame",
           {{"timestamp", Time()}, {"frame_id", String()}, {"poses", ArrayOf(Pose())}},
           {"timestamp", "frame_id", "poses"}));
  return *kSchema;
}

const ChannelSchema& LoopClosuresSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("loop_closures", "waymark.LoopClosures",
           {{"timestamp", Time()},
            {"loop_closures", Integer()},    // SlamUpdate.loop_closures: accepted so far
            {"new_closures", Integer()},     // since the previous message of this channel
            {"graph_revision", Integer()},   // SlamUpdate.graph_revision
            {"scans_processed", Integer()},
            {"pose", Pose()}},               // where the robot was when they were seen
           {"timestamp", "loop_closures", "new_closures", "graph_revision"}));
  return *kSchema;
}

const ChannelSchema& ConfidenceSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("confidence", "waymark.Confidence",
           {{"timestamp", Time()},
            {"covariance", ArrayOf(Number())},  // 3x3 of (x, y, theta), row-major; laser
            {"sigma_x", Number()},              // m, sqrt of the covariance's diagonal
            {"sigma_y", Number()},
            {"sigma_theta", Number()},          // rad
            {"covariance_trace_mean", Number()},
            {"segments", Integer()},
            {"matched_segments", Integer()},
            {"observed_segments", Integer()},
            // slam.proto's LocalizationStatus / VisualTrackingQuality as protobuf JSON, when the
            // answer carries one.
            {"localization", {{"type", "object"}}},
            {"tracking", {{"type", "object"}}}},
           {"timestamp"}));
  return *kSchema;
}

const ChannelSchema& VisualFrameSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("vo", "waymark.VisualFrame",
           {{"timestamp", Time()},
            {"state", String()},  // VisualFrameInfo.TrackingState
            {"keyframe", Boolean()},
            {"relocalized", Boolean()},
            {"counts", {{"type", "object"}}},   // FeatureCounts: features per class
            {"quality", {{"type", "object"}}},  // VisualTrackingQuality
            {"boxes", ArrayOf({{"type", "object"}})},
            {"pose", Pose()}},
           {"timestamp", "state", "counts"}));
  return *kSchema;
}

const ChannelSchema& RecognitionSchema() {
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("recognitions", "waymark.Recognition",
           {{"timestamp", Time()},
            {"database", String()},
            // crossing.proto's RecognizeResponse as protobuf JSON, without its candidates list.
            {"answer", {{"type", "object"}}}},
           {"timestamp", "database", "answer"}));
  return *kSchema;
}

const ChannelSchema& SessionsSchema() {
  json session = Object(nullptr,
                        {{"session_id", String()},
                         {"robot_id", String()},
                         {"name", String()},
                         {"kind", String()},
                         {"scans_processed", Integer()},
                         {"resident", Boolean()},
                         {"topics", ArrayOf(String())}},
                        {"session_id", "robot_id", "kind", "topics"});
  static const ChannelSchema* const kSchema = new ChannelSchema(
      Make("sessions", "waymark.Sessions",
           {{"timestamp", Time()}, {"sessions", ArrayOf(session)}}, {"timestamp", "sessions"}));
  return *kSchema;
}

}  // namespace waymark::service::live
