#include "tests/fuzz/fuzz_targets.h"

#include <memory>
#include <optional>
#include <string>

#include <opencv2/imgproc.hpp>

#include "client/datasets/carmen_log.h"
#include "client/datasets/pgm_image.h"
#include "client/datasets/pose_file.h"
#include "client/devices/lms200_telegram.h"
#include "client/devices/p2os_packet.h"
#include "client/devices/p2os_sip.h"
#include "client/eval/relations_metric.h"
#include "client/sim/sim_builtin_worlds.h"
#include "client/sim/sim_scene.h"
#include "client/sim/sim_world.h"
#include "server/crossing/features.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/mapping/localizer.h"
#include "server/laser_slam/mapping/node_feed_codec.h"
#include "server/service/slam/slam_params.h"
#include "server/service/slam/visual_frame_decoder.h"
#include "server/service/slam/visual_params.h"
#include "server/visual_slam/visual_odometry.h"
#include "tests/fuzz/fuzz_images.h"

namespace waymark::fuzz {
namespace {

std::string Text(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// --- CARMEN log lines (waymark slam replay, the laser bench) ----------------------------------
void CarmenLine(const uint8_t* data, size_t size) {
  adapters::CarmenRecord record;
  (void)adapters::ParseCarmenLine(Text(data, size), 1, &record);
}
std::vector<std::string> CarmenSeeds() {
  return {"ODOM 1.0 2.0 0.5 0.1 0.0 0.0 12.5 host 12.5",
          "FLASER 5 1.0 2.0 3.0 4.0 5.0 0.1 0.2 0.3 0.1 0.2 0.3 12.6 host 12.6",
          "ROBOTLASER1 0 -1.5708 3.1416 0.7854 81.9 0.01 0 5 1.0 1.5 2.0 2.5 3.0 0 0.1 0.2 0.3 "
          "0.1 0.2 0.3 0.1 0.1 0 0 0 0 12.7 host 12.7",
          "PARAM robot_front_laser_max 81.9", "# comment"};
}

// --- TUM / KITTI pose files and KITTI times.txt (vo run, eval ate) -----------------------------
void PoseText(const uint8_t* data, size_t size) {
  const std::string text = Text(data, size);
  (void)cli::ParsePoseText(text);
  (void)cli::ParseStampList(text);
}
std::vector<std::string> PoseSeeds() {
  return {"# timestamp tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n1.1 0.1 0 0 0 0 0.0499792 0.99875\n",
          "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.5 0 1 0 0 0 0 1 1.2\n", "0.0\n0.1\n0.2\n"};
}

// --- PGM images (map import) ------------------------------------------------------------------
void Pgm(const uint8_t* data, size_t size) {
  (void)cli::ParsePgm(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz");
}
std::vector<std::string> PgmSeeds() {
  return {std::string("P5\n4 2\n255\n") + std::string("\x00\x7f\xff\x10\x20\x30\x40\x50", 8),
          "P2\n# c\n3 1\n255\n0 128 255\n"};
}

// --- Relations files (the laser benchmarks' ground truth) and simulator world files -------------
void Relations(const uint8_t* data, size_t size) { (void)cli::ParseRelations(Text(data, size)); }
std::vector<std::string> RelationsSeeds() {
  return {"1.0 2.0 0.5 0.0 0 0.1\n2.0 3.5 0.4 0.1 0 -0.05\n",
          "# comment\n10.5 20.25 -1.0 0.25 0 3.1\n"};
}
void World(const uint8_t* data, size_t size) { (void)adapters::ParseWorld(Text(data, size)); }
std::vector<std::string> WorldSeeds() {
  std::vector<std::string> seeds;
  for (const char* name : {"corridor", "office", "cluttered"}) {
    if (const char* text = adapters::BuiltinWorldText(name)) seeds.push_back(text);
  }
  return seeds;
}

// --- Serial byte streams: the Pioneer's P2OS packets and the LMS200's telegrams -----------------
std::string Bytes(const std::vector<std::uint8_t>& bytes) {
  return std::string(bytes.begin(), bytes.end());
}
// Feeds a serial parser in two reads split at `split` (as a serial port delivers: an item may
// straddle them) and decodes every item it yields.
template <class Parser, class Decode>
void FeedInTwoReads(const uint8_t* data, size_t size, size_t split, Decode decode) {
  Parser parser;
  parser.Feed(data, split);
  parser.Feed(data + split, size - split);
  while (auto item = parser.Next()) decode(*item);
}
void P2osStream(const uint8_t* data, size_t size) {
  FeedInTwoReads<adapters::P2osParser>(data, size, size / 2, [](const adapters::P2osPacket& p) {
    (void)adapters::DecodeStandardSip(p);
  });
}
std::vector<std::string> P2osSeeds() {
  adapters::StandardSip sip;
  std::vector<std::string> seeds;
  auto packet = adapters::EncodeP2osPacket(0x32, adapters::EncodeStandardSipPayload(sip));
  if (packet.ok()) seeds.push_back(Bytes(*packet) + Bytes(*packet));
  auto command = adapters::EncodeP2osCommand(11, 300);
  if (command.ok()) seeds.push_back(Bytes(*command));
  return seeds;
}
void Lms200Stream(const uint8_t* data, size_t size) {
  FeedInTwoReads<adapters::Lms200Parser>(
      data, size, size / 3,
      [](const adapters::Lms200Telegram& t) { (void)adapters::DecodeLms200Scan(t); });
}
std::vector<std::string> Lms200Seeds() {
  // A scan reply: command 0xB0, count word 361 values in cm, then the values.
  std::vector<std::uint8_t> reply = {0xB0, 0x69, 0x01};
  for (int i = 0; i < 361; ++i) {
    reply.push_back(static_cast<std::uint8_t>(200 + i % 50));
    reply.push_back(0x00);
  }
  std::vector<std::string> seeds;
  auto telegram = adapters::EncodeLms200Telegram(reply, 0x80);
  if (telegram.ok()) seeds.push_back(std::string("\x06") + Bytes(*telegram));
  return seeds;
}

// The camera of the targets that admit frames: the size of FuzzView's images.
visual_slam::CameraModel FuzzCamera() {
  visual_slam::CameraModel camera;
  camera.fx = camera.fy = 100;
  camera.cx = kViewWidth / 2.0;
  camera.cy = kViewHeight / 2.0;
  camera.width = kViewWidth;
  camera.height = kViewHeight;
  return camera;
}

// --- Image decoding: any bytes as a crossing view (decoding, the working resolution, SIFT, the
// hue histogram), as a visual session's camera image and as its 16-bit depth image -------------
void ImageDecoding(const uint8_t* data, size_t size) {
  const std::string bytes = Text(data, size);
  crossing::FeatureOptions options;
  options.work_width = kViewWidth;
  options.work_height = kViewHeight;
  // Two of the options that change the path, picked by the input's length so both are fuzzed.
  options.keep_aspect = (size & 1) != 0;
  options.global_descriptor = (size & 2) != 0;
  (void)crossing::ExtractFeatures(bytes, options, nullptr);
  v1::ImageFrame frame;
  frame.set_stamp(1);
  frame.set_image(bytes);
  (void)service::DecodeFrame(frame, 1, FuzzCamera());
  static const std::string* const image = new std::string(adapters::EncodeJpeg(FuzzView(3, 0)));
  frame.set_image(*image);
  frame.set_depth(bytes);
  (void)service::DecodeFrame(frame, 2, FuzzCamera());
}
std::vector<std::string> ImageSeeds() {
  cv::Mat gray;
  cv::cvtColor(FuzzView(4, 90), gray, cv::COLOR_BGR2GRAY);
  return {adapters::EncodeJpeg(FuzzView(4, 0)), adapters::EncodePng(FuzzView(4, 180)),
          adapters::EncodePng(gray), adapters::EncodePng(FuzzDepth())};
}

// --- Request messages: a robot's SensorData (odometry, scans, camera frames with their image
// decoding and admission) and a session's configuration, parsed and checked as the server does -
void SensorData(const uint8_t* data, size_t size) {
  v1::SensorData message;
  if (!message.ParseFromArray(data, static_cast<int>(size))) return;
  laser_slam::ScanGeometry geometry;
  geometry.angle_min = -1.5707963;
  geometry.angle_increment = 3.1415926 / 180;
  geometry.beam_count = 181;
  if (message.has_odometry()) (void)service::ToOdometryReading(message.odometry());
  if (message.has_scan()) (void)service::ToLaserScan(message.scan(), geometry);
  if (message.has_frame()) (void)service::DecodeFrame(message.frame(), message.sequence(), FuzzCamera());
}
std::vector<std::string> SensorSeeds() {
  v1::SensorData odometry;
  odometry.set_sequence(1);
  odometry.mutable_odometry()->set_stamp(1.5);
  odometry.mutable_odometry()->mutable_pose()->set_x(0.5);
  v1::SensorData scan;
  scan.set_sequence(2);
  scan.mutable_scan()->set_stamp(1.6);
  for (int i = 0; i < 181; ++i) scan.mutable_scan()->add_ranges(2.0f);
  v1::SensorData frame;
  frame.set_sequence(3);
  frame.mutable_frame()->set_stamp(1.7);
  // An image of the camera's size, so that it is decoded (made by code: a literal PNG here was
  // cut short by escapes like "\x9cc", which read as one out-of-range character).
  frame.mutable_frame()->set_image(adapters::EncodePng(FuzzView(3, 0)));
  auto* box = frame.mutable_frame()->add_boxes();
  box->set_x(1);
  box->set_width(10);
  box->set_height(10);
  return {odometry.SerializeAsString(), scan.SerializeAsString(), frame.SerializeAsString()};
}
void SessionConfig(const uint8_t* data, size_t size) {
  v1::CreateSessionRequest request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return;
  if (request.has_laser()) (void)service::ToLaserSessionOptions(request.laser());
  if (request.has_visual()) (void)service::ToVisualSessionOptions(request.visual());
}
std::vector<std::string> SessionSeeds() {
  v1::CreateSessionRequest laser;
  laser.mutable_laser()->mutable_params();
  v1::CreateSessionRequest visual;
  visual.mutable_visual()->mutable_camera()->set_fx(500);
  visual.mutable_visual()->mutable_camera()->set_fy(500);
  visual.mutable_visual()->mutable_camera()->set_cx(320);
  visual.mutable_visual()->mutable_camera()->set_cy(240);
  visual.mutable_visual()->mutable_camera()->set_width(640);
  visual.mutable_visual()->mutable_camera()->set_height(480);
  visual.mutable_visual()->mutable_params()->set_bundle_window(5);
  return {laser.SerializeAsString(), visual.SerializeAsString()};
}

// --- Laser SLAM checkpoints read back from storage ---------------------------------------------
laser_slam::LaserScan FuzzScan(double stamp) {
  laser_slam::LaserScan scan;
  scan.stamp = stamp;
  scan.geometry.angle_min = -1.5707963;
  scan.geometry.angle_increment = 3.1415926 / 180;
  scan.geometry.beam_count = 181;
  for (int i = 0; i < 181; ++i) scan.ranges.push_back(i < 90 ? 2.0f : 3.0f);
  return scan;
}
// A localization session's localizer, on a map of one wall: what a localization checkpoint is
// restored with.
std::unique_ptr<laser_slam::MapLocalizer> FuzzLocalizer() {
  laser_slam::PointCloud wall;
  for (int i = 0; i < 40; ++i) wall.emplace_back(2.0f, -1.0f + 0.05f * i);
  auto localizer = laser_slam::MapLocalizer::Create(laser_slam::LocalizationOptions{}, wall);
  return localizer.ok() ? std::move(*localizer) : nullptr;
}
void LaserCheckpoint(const uint8_t* data, size_t size) {
  const std::string state = Text(data, size);
  auto slam = laser_slam::LaserSlam::FromCheckpoint(laser_slam::SlamOptions{}, state, {});
  // A localization session's checkpoint is refused without its localizer: read it with one.
  if (absl::IsFailedPrecondition(slam.status())) {
    slam = laser_slam::LaserSlam::FromCheckpoint(laser_slam::SlamOptions{}, state, {},
                                                 FuzzLocalizer());
  }
  if (slam.ok()) (void)(*slam)->AddScan(FuzzScan(1e6));
}
std::vector<std::string> LaserSeeds() {
  laser_slam::LaserSlam slam{laser_slam::SlamOptions{}};
  laser_slam::LaserSlam localizing{laser_slam::SlamOptions{}, FuzzLocalizer()};
  std::vector<std::string> seeds = {slam.SerializeState(), localizing.SerializeState()};
  for (int k = 0; k < 3; ++k) {
    for (laser_slam::LaserSlam* s : {&slam, &localizing}) {
      (void)s->AddOdometry({1.0 + k, laser_slam::Pose2{0.2 * k, 0, 0}});
      (void)s->AddScan(FuzzScan(1.0 + k));
    }
  }
  seeds.push_back(slam.SerializeState());
  seeds.push_back(localizing.SerializeState());
  return seeds;
}

// --- A shared map's node feed read back from the database (another server wrote it) ------------
// The first byte picks the part: the poses (and loops) or one node's points.
void NodeFeed(const uint8_t* data, size_t size) {
  if (size == 0) return;
  const std::string bytes = Text(data + 1, size - 1);
  if (data[0] % 2 == 0) {
    auto poses = laser_slam::DecodeFeedPoses(bytes);
    if (poses.ok()) (void)laser_slam::EncodeFeedPoses(poses->nodes, poses->loops);
  } else {
    auto points = laser_slam::DecodeFeedPoints(bytes);
    if (points.ok()) (void)laser_slam::EncodeFeedPoints(*points);
  }
}
std::vector<std::string> NodeFeedSeeds() {
  std::vector<laser_slam::NodeView> nodes(3);
  for (int i = 0; i < 3; ++i) {
    nodes[i].scan = 2 * i + 1;
    nodes[i].stamp = 0.5 * i;
    nodes[i].global = laser_slam::Pose2{0.3 * i, 0.1 * i, 0.05 * i};
    nodes[i].step_sigma = Eigen::Vector3d(0.01, 0.01, 0.002);
  }
  laser_slam::GraphConstraint loop;
  loop.kind = laser_slam::GraphConstraint::Kind::kLoop;
  loop.from = 0;
  loop.to = 2;
  loop.relative = laser_slam::Pose2{0.6, 0.2, 0.1};
  laser_slam::PointCloud points = {{1.0f, 2.0f}, {-3.0f, 0.5f}};
  return {std::string(1, '\0') + laser_slam::EncodeFeedPoses(nodes, {loop}),
          std::string(1, '\1') + laser_slam::EncodeFeedPoints(points)};
}

// --- Visual odometry states (a visual session's checkpoint) ------------------------------------
std::unique_ptr<visual_slam::VisualOdometry> FuzzOdometry() {
  visual_slam::CameraModel camera;
  camera.fx = camera.fy = 500;
  camera.cx = 320;
  camera.cy = 240;
  camera.width = 640;
  camera.height = 480;
  visual_slam::VisualOdometryOptions options;
  options.bundle_window = 5;
  options.relocalization_keyframes = 5;
  auto odometry = visual_slam::VisualOdometry::Create(options, camera, nullptr);
  return odometry.ok() ? std::move(*odometry) : nullptr;
}
void VisualState(const uint8_t* data, size_t size) {
  std::unique_ptr<visual_slam::VisualOdometry> odometry = FuzzOdometry();
  if (odometry && odometry->RestoreState(Text(data, size)).ok()) (void)odometry->SerializeState();
}
std::vector<std::string> VisualSeeds() {
  std::unique_ptr<visual_slam::VisualOdometry> odometry = FuzzOdometry();
  return {odometry->SerializeState()};
}

}  // namespace

const std::vector<FuzzTarget>& Targets() {
  static const std::vector<FuzzTarget> targets = {
      {"carmen_line", CarmenLine, CarmenSeeds},
      {"pose_text", PoseText, PoseSeeds},
      {"pgm", Pgm, PgmSeeds},
      {"p2os_stream", P2osStream, P2osSeeds},
      {"lms200_stream", Lms200Stream, Lms200Seeds},
      {"relations", Relations, RelationsSeeds},
      {"world", World, WorldSeeds},
      {"sensor_data", SensorData, SensorSeeds},
      {"session_config", SessionConfig, SessionSeeds},
      {"laser_checkpoint", LaserCheckpoint, LaserSeeds},
      {"node_feed", NodeFeed, NodeFeedSeeds},
      {"visual_state", VisualState, VisualSeeds},
      {"image_decoding", ImageDecoding, ImageSeeds},
      CrossingRequestsTarget(),
      SlamRequestsTarget(),
      TokenRequestsTarget(),
      BagFilesTarget(),
      RosMessagesTarget(),
  };
  return targets;
}

}  // namespace waymark::fuzz
