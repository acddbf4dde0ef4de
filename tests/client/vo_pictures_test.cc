// Pictures and results of `waymark vo run` on synthetic input: the feature frame (size, colours
// at feature and box pixels), the trajectory scene with aligned ground truth, the TUM writer read
// back by pose_file, summary fields, and records made from SlamUpdates.
#include "client/sessions/vo_pictures.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "client/datasets/pose_file.h"
#include "client/render/vo_frames.h"
#include "client/eval/vo_summary.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::ReadAll;
using waymark::testing::ScopedTempDir;

cv::Vec3b At(const cv::Mat& image, int x, int y) { return image.at<cv::Vec3b>(y, x); }
cv::Vec3b Bgr(const cv::Scalar& s) {
  return cv::Vec3b(static_cast<uint8_t>(s[0]), static_cast<uint8_t>(s[1]),
                   static_cast<uint8_t>(s[2]));
}

TEST(VoPicturesTest, FeaturesAndBoxesInTheirColours) {
  const cv::Mat gray(120, 200, CV_8UC1, cv::Scalar(128));
  const std::vector<VoFeature> features = {{50, 60, VoFeatureLabel::kStatic},
                                           {100, 60, VoFeatureLabel::kDynamic},
                                           {120, 60, VoFeatureLabel::kStaticInBox},
                                           {140, 60, VoFeatureLabel::kPotentiallyDynamic},
                                           {20, 60, VoFeatureLabel::kUnmatched}};
  const std::vector<VoBox> boxes = {{90, 40, 60, 50, "person", 0.9f}};
  absl::StatusOr<cv::Mat> drawn = DrawFeatureFrame(gray, features, boxes, "caption");
  ASSERT_TRUE(drawn.ok()) << drawn.status();
  EXPECT_EQ(drawn->size(), gray.size());
  EXPECT_EQ(drawn->type(), CV_8UC3);
  EXPECT_EQ(At(*drawn, 50, 60), cv::Vec3b(0, 200, 0));   // static: green
  EXPECT_EQ(At(*drawn, 52, 61), cv::Vec3b(0, 200, 0));   // inside the disc of radius 3
  EXPECT_EQ(At(*drawn, 100, 60), cv::Vec3b(0, 0, 255));  // dynamic: red
  EXPECT_EQ(At(*drawn, 120, 60), Bgr(FeatureColor(VoFeatureLabel::kStaticInBox)));
  EXPECT_GT(At(*drawn, 120, 60)[0], 200);  // blue dominates
  EXPECT_EQ(At(*drawn, 140, 60), Bgr(FeatureColor(VoFeatureLabel::kPotentiallyDynamic)));
  EXPECT_EQ(At(*drawn, 20, 60), Bgr(FeatureColor(VoFeatureLabel::kUnmatched)));
  // The box outline (2 px) at the middle of its left and bottom edges; the background elsewhere.
  EXPECT_EQ(At(*drawn, 90, 65), Bgr(BoxColor()));
  EXPECT_EQ(At(*drawn, 110, 89), Bgr(BoxColor()));
  EXPECT_EQ(At(*drawn, 70, 30), cv::Vec3b(128, 128, 128));

  EXPECT_FALSE(DrawFeatureFrame(cv::Mat(), {}, {}, "").ok());
  EXPECT_FALSE(DrawFeatureFrame(cv::Mat(10, 10, CV_16UC1), {}, {}, "").ok());
}

TEST(VoPicturesTest, ColourImageKeepsItsPixelsAwayFromFeatures) {
  const cv::Mat colour(100, 100, CV_8UC3, cv::Scalar(10, 20, 30));
  absl::StatusOr<cv::Mat> drawn =
      DrawFeatureFrame(colour, {{30, 40, VoFeatureLabel::kStatic}}, {}, "");
  ASSERT_TRUE(drawn.ok());
  EXPECT_EQ(At(*drawn, 30, 40), cv::Vec3b(0, 200, 0));
  EXPECT_EQ(At(*drawn, 70, 40), cv::Vec3b(10, 20, 30));
}

TEST(VoPicturesTest, WriteFeatureFrameWritesAPngOfTheFrameSize) {
  ScopedTempDir dir;
  const std::filesystem::path in = dir.Make("in.png");
  cv::imwrite(in.string(), cv::Mat(48, 64, CV_8UC3, cv::Scalar(200, 200, 200)));
  VoFrameRecord record;
  record.features = {{10, 20, VoFeatureLabel::kStatic}};
  const std::filesystem::path out = dir.Make("frames/000007.png");
  ASSERT_TRUE(WriteFeatureFrame(in, record, "", out).ok());
  const cv::Mat read = cv::imread(out.string());
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(read.cols, 64);
  EXPECT_EQ(read.rows, 48);
  EXPECT_EQ(At(read, 10, 20), cv::Vec3b(0, 200, 0));

  absl::Status missing = WriteFeatureFrame(dir.path() / "none.png", record, "", out);
  EXPECT_EQ(missing.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(missing.message(), HasSubstr("none.png"));
}

TEST(VoPicturesTest, TrajectorySceneMapsGroundTruthIntoTheEstimateFrame) {
  // Estimate along z; the ground truth is the same path rotated 90 degrees about y and shifted.
  std::vector<StampedPose3> estimate;
  for (int i = 0; i < 5; ++i) {
    StampedPose3 p;
    p.stamp = i;
    p.translation = Eigen::Vector3d(0.1 * i, 0, 0.5 * i);
    estimate.push_back(p);
  }
  TrajectoryEvaluation evaluation;
  evaluation.alignment.rotation = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).matrix();
  evaluation.alignment.translation = Eigen::Vector3d(3, 1, -2);
  for (const StampedPose3& p : estimate) {
    evaluation.groundtruth_positions.push_back(evaluation.alignment.Apply(p.translation));
  }
  const MapScene scene = TrajectoryScene(estimate, evaluation, "title");
  EXPECT_EQ(scene.title, "title");
  ASSERT_EQ(scene.polylines.size(), 1u);
  ASSERT_EQ(scene.references.size(), 1u);
  ASSERT_EQ(scene.references[0].points.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR(scene.polylines[0].points[i].x, 0.1 * i, 1e-12);
    EXPECT_NEAR(scene.polylines[0].points[i].y, 0.5 * i, 1e-12);  // z is drawn upwards
    EXPECT_NEAR(scene.references[0].points[i].x, 0.1 * i, 1e-9);
    EXPECT_NEAR(scene.references[0].points[i].y, 0.5 * i, 1e-9);
  }
  EXPECT_TRUE(TrajectoryScene(estimate, std::nullopt, "").references.empty());
  // Both paths marked at their ends; the camera (identity rotation: looking along +z) faces up
  // the picture from its last position.
  EXPECT_TRUE(scene.polylines[0].mark_ends);
  EXPECT_TRUE(scene.references[0].mark_ends);
  ASSERT_TRUE(scene.current_pose.has_value());
  EXPECT_NEAR(scene.current_pose->position.x, 0.4, 1e-12);
  EXPECT_NEAR(scene.current_pose->position.y, 2.0, 1e-12);
  EXPECT_NEAR(scene.current_pose->heading, M_PI / 2, 1e-12);
  std::vector<StampedPose3> turned = estimate;
  turned.back().rotation = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()).matrix();
  EXPECT_NEAR(TrajectoryScene(turned, std::nullopt, "").current_pose->heading, M_PI, 1e-12);

  ScopedTempDir dir;
  ASSERT_TRUE(WriteMapPictures(scene, dir.path() / "t.svg", dir.path() / "t.png",
                               TrajectoryRenderOptions())
                  .ok());
  const std::string svg = ReadAll(dir.path() / "t.svg");
  EXPECT_THAT(svg, HasSubstr("<svg"));
  EXPECT_THAT(svg, HasSubstr("ground truth (aligned)"));
  EXPECT_THAT(svg, Not(HasSubstr("segment, both endpoints real")));  // no segment legend
}

TEST(VoSummaryTest, TumPosesReadBackByPoseFile) {
  std::vector<StampedPose3> poses(2);
  poses[0].stamp = 1548339828.92438;
  poses[1].stamp = 1548339828.95789;
  poses[1].translation = Eigen::Vector3d(0.25, -0.5, 1.0);
  poses[1].rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  std::ostringstream text;
  WriteTumPoses(text, poses);
  absl::StatusOr<PoseFile> read = ParsePoseText(text.str());
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(read->format, PoseFormat::kTum);
  ASSERT_EQ(read->poses.size(), 2u);
  EXPECT_NEAR(read->poses[0].stamp, 1548339828.92438, 1e-6);
  EXPECT_NEAR(read->poses[1].stamp, 1548339828.95789, 1e-6);
  EXPECT_TRUE(read->poses[1].translation.isApprox(poses[1].translation, 1e-9));
  EXPECT_TRUE(read->poses[1].rotation.isApprox(poses[1].rotation, 1e-8));
}

TEST(VoSummaryTest, QuantileInterpolates) {
  EXPECT_DOUBLE_EQ(Quantile({}, 0.5), 0);
  EXPECT_DOUBLE_EQ(Quantile({4, 1, 3, 2}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(Quantile({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, 0.9), 10);
  EXPECT_DOUBLE_EQ(Quantile({1, 2}, 0.9), 1.9);
}

TEST(VoSummaryTest, FrameSummaryCountsAndStages) {
  std::vector<VoFrameRecord> records(4);
  for (size_t i = 0; i < records.size(); ++i) {
    records[i].index = i;
    records[i].answered = true;
    records[i].state = "tracking";
    records[i].total = 100;
    records[i].dynamic = static_cast<uint32_t>(i);
    records[i].stage_ms[1] = 10.0 * (i + 1);  // orb
  }
  records[0].keyframe = true;
  records[1].bundle_ms = 12.0;  // an adjustment applied before frames 1 and 2
  records[2].bundle_ms = 20.0;
  records[2].relocalized = true;
  records[2].state = "lost";
  records[3].rejected = true;  // not counted as processed
  VoFrameRecord unanswered;
  records.push_back(unanswered);
  const nlohmann::json s = FrameSummary(records);
  EXPECT_EQ(s["frames"], 5);
  EXPECT_EQ(s["processed"], 3);
  EXPECT_EQ(s["rejected"], 1);
  EXPECT_EQ(s["frames_unanswered"], 1);
  EXPECT_EQ(s["lost_frames"], 1);
  EXPECT_EQ(s["keyframes"], 1);
  EXPECT_EQ(s["features_total"], 300);
  EXPECT_EQ(s["features_dynamic"], 3);
  EXPECT_DOUBLE_EQ(s["orb_ms_median"].get<double>(), 20.0);
  EXPECT_DOUBLE_EQ(s["orb_ms_p90"].get<double>(), 28.0);
  EXPECT_EQ(s["bundle_adjustments"], 2);  // over the frames that had one, not every frame
  EXPECT_DOUBLE_EQ(s["bundle_ms_median"].get<double>(), 16.0);
  EXPECT_EQ(s["relocalized_frames"], 1);
  EXPECT_DOUBLE_EQ(s["bundle_wait_ms_median"].get<double>(), 0.0);
  EXPECT_EQ(ProcessedPoses(records).size(), 3u);
}

TEST(VoFramesTest, RecordFromUpdate) {
  v1::SlamUpdate update;
  update.set_sequence(3);
  v1::Pose3D* pose = update.mutable_pose3d();
  pose->set_x(1);
  pose->set_z(2);
  pose->set_qy(std::sin(0.25));
  pose->set_qw(std::cos(0.25));
  v1::VisualFrameInfo* info = update.mutable_visual();
  info->set_state(v1::VisualFrameInfo::LOST);
  info->set_keyframe(true);
  info->mutable_counts()->set_total(500);
  info->mutable_counts()->set_dynamic(12);
  info->mutable_timings()->set_orb_ms(4.5);
  info->mutable_timings()->set_total_ms(20);
  info->mutable_timings()->set_bundle_ms(14);
  info->mutable_timings()->set_bundle_wait_ms(3);
  info->set_relocalized(true);
  v1::BoundingBox* box = info->add_boxes();
  box->set_x(5);
  box->set_width(10);
  box->set_label("person");
  info->add_feature_xy(7);
  info->add_feature_xy(8);
  info->add_feature_labels(v1::VisualFrameInfo::DYNAMIC);
  const VoFrameRecord r = RecordFromUpdate(update, 9, 1.5);
  EXPECT_EQ(r.index, 9u);
  EXPECT_TRUE(r.answered);
  EXPECT_FALSE(r.rejected);
  EXPECT_EQ(r.state, "lost");
  EXPECT_TRUE(r.keyframe);
  EXPECT_EQ(r.total, 500u);
  EXPECT_EQ(r.dynamic, 12u);
  EXPECT_DOUBLE_EQ(r.stage_ms[1], 4.5);
  EXPECT_DOUBLE_EQ(r.stage_ms[7], 20);
  EXPECT_DOUBLE_EQ(r.stage_ms[8], 3);  // bundle_wait
  EXPECT_DOUBLE_EQ(r.bundle_ms, 14);
  EXPECT_TRUE(r.relocalized);
  EXPECT_DOUBLE_EQ(r.pose.stamp, 1.5);
  EXPECT_DOUBLE_EQ(r.pose.translation.z(), 2);
  EXPECT_NEAR(RotationAngle(r.pose.rotation), 0.5, 1e-12);
  ASSERT_EQ(r.boxes.size(), 1u);
  EXPECT_EQ(r.boxes[0].label, "person");
  ASSERT_EQ(r.features.size(), 1u);
  EXPECT_EQ(r.features[0].label, VoFeatureLabel::kDynamic);
  EXPECT_FLOAT_EQ(r.features[0].y, 8);

  info->add_feature_xy(1);  // odd count: the feature data is dropped, not misdrawn
  EXPECT_TRUE(RecordFromUpdate(update, 9, 1.5).features.empty());

  v1::SlamUpdate rejected;
  rejected.mutable_rejection()->set_code(3);
  rejected.mutable_rejection()->set_message("bad image");
  const VoFrameRecord rr = RecordFromUpdate(rejected, 2, 0.5);
  EXPECT_TRUE(rr.rejected);
  EXPECT_EQ(rr.rejection_code, 3);
  EXPECT_EQ(rr.rejection_message, "bad image");
}

}  // namespace
}  // namespace waymark::cli
