// The visual odometry pipeline end to end: admission errors, synthetic frames with a known camera
// motion and a known moving object, and short real windows with an ATE floor.

#include "server/visual_slam/visual_odometry.h"

#include <cstdlib>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "server/visual_slam/camera_check.h"
#include "tests/visual_slam/sequence_fixture.h"

namespace waymark::visual_slam {
namespace {

using testing::RandomTexture;
using testing::SyntheticCamera;

std::unique_ptr<VisualOdometry> Make(const VisualOdometryOptions& options = {},
                                     const CameraModel& camera = SyntheticCamera()) {
  absl::StatusOr<std::unique_ptr<VisualOdometry>> odometry =
      VisualOdometry::Create(options, camera, nullptr);
  EXPECT_TRUE(odometry.ok()) << odometry.status();
  return odometry.ok() ? *std::move(odometry) : nullptr;
}

// Frame k of a camera sliding sideways in front of a fronto-parallel textured wall at depth
// `wall_depth` m: each frame the view shifts `shift_px` pixels (camera motion +x of
// shift_px * wall_depth / f metres).
FrameInput SlidingFrame(const cv::Mat& texture, int k, int shift_px, double wall_depth) {
  FrameInput frame;
  frame.stamp = 0.1 * k;
  frame.image = texture(cv::Rect(k * shift_px, 0, 640, 480)).clone();
  frame.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(wall_depth * 5000));
  return frame;
}

TEST(VisualOdometryTest, RefusesBadCameraAndOptions) {
  CameraModel camera = SyntheticCamera();
  camera.fx = 0;
  absl::StatusOr<std::unique_ptr<VisualOdometry>> odometry =
      VisualOdometry::Create({}, camera, nullptr);
  EXPECT_EQ(odometry.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(odometry.status().message().find("focal"), std::string::npos);

  camera = SyntheticCamera();
  camera.cx = 5000;
  EXPECT_EQ(VisualOdometry::Create({}, camera, nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);
  // Finite but not a camera: a focal length of 1e300 pixels, a distortion of 1e9.
  camera = SyntheticCamera();
  camera.fx = 1e300;
  EXPECT_EQ(VisualOdometry::Create({}, camera, nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);
  camera = SyntheticCamera();
  camera.distortion = {1e9, 0, 0, 0, 0};
  EXPECT_EQ(VisualOdometry::Create({}, camera, nullptr).status().code(),
            absl::StatusCode::kInvalidArgument);

  VisualOdometryOptions options;
  options.delta = 0;
  odometry = VisualOdometry::Create(options, SyntheticCamera(), nullptr);
  EXPECT_EQ(odometry.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(odometry.status().message().find("delta"), std::string::npos);

  options = {};
  options.bundle_window = 2;  // too small for a monocular gauge (two held keyframes)
  odometry = VisualOdometry::Create(options, SyntheticCamera(), nullptr);
  EXPECT_EQ(odometry.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(odometry.status().message().find("bundle_window"), std::string::npos);
}

TEST(VisualOdometryTest, RejectsBadFramesAndKeepsTheSession) {
  std::unique_ptr<VisualOdometry> odometry = Make();
  ASSERT_NE(odometry, nullptr);
  const cv::Mat texture = RandomTexture(1200, 480, 7);
  ASSERT_TRUE(odometry->ProcessFrame(SlidingFrame(texture, 0, 4, 2.0)).ok());

  FrameInput late = SlidingFrame(texture, 1, 4, 2.0);
  late.stamp = -1;
  absl::Status status = odometry->ProcessFrame(late).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("time order"), std::string::npos) << status;
  late.stamp = 0;  // equal to the last stamp
  EXPECT_EQ(odometry->ProcessFrame(late).status().code(), absl::StatusCode::kInvalidArgument);

  FrameInput small = SlidingFrame(texture, 1, 4, 2.0);
  cv::resize(small.image, small.image, cv::Size(320, 240));
  status = odometry->ProcessFrame(small).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("320x240"), std::string::npos) << status;

  FrameInput float_image = SlidingFrame(texture, 1, 4, 2.0);
  float_image.image.convertTo(float_image.image, CV_32F);
  EXPECT_EQ(odometry->ProcessFrame(float_image).status().code(),
            absl::StatusCode::kInvalidArgument);

  FrameInput byte_depth = SlidingFrame(texture, 1, 4, 2.0);
  byte_depth.depth.convertTo(byte_depth.depth, CV_8U);
  status = odometry->ProcessFrame(byte_depth).status();
  EXPECT_NE(status.message().find("16-bit"), std::string::npos) << status;

  FrameInput no_depth = SlidingFrame(texture, 1, 4, 2.0);
  no_depth.depth = cv::Mat();
  status = odometry->ProcessFrame(no_depth).status();
  EXPECT_NE(status.message().find("RGB-D"), std::string::npos) << status;

  FrameInput nan_box = SlidingFrame(texture, 1, 4, 2.0);
  nan_box.boxes = std::vector<Box>{{0, 0, std::nanf(""), 10, "person", 1}};
  EXPECT_EQ(odometry->ProcessFrame(nan_box).status().code(), absl::StatusCode::kInvalidArgument);
  FrameInput huge_box = SlidingFrame(texture, 1, 4, 2.0);
  huge_box.boxes = std::vector<Box>{{-3e38f, 0, 3e38f, 10, "person", 1}};
  EXPECT_EQ(odometry->ProcessFrame(huge_box).status().code(), absl::StatusCode::kInvalidArgument);
  FrameInput far_future = SlidingFrame(texture, 1, 4, 2.0);
  far_future.stamp = 1e300;
  EXPECT_EQ(odometry->ProcessFrame(far_future).status().code(),
            absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(odometry->trajectory().size(), 1u);  // nothing above changed the session
  absl::StatusOr<FrameResult> next = odometry->ProcessFrame(SlidingFrame(texture, 1, 4, 2.0));
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_EQ(next->state, TrackingState::kTracking);
  EXPECT_EQ(odometry->trajectory().size(), 2u);
}

TEST(VisualOdometryTest, RecoversAKnownSidewaysMotionWithDepth) {
  std::unique_ptr<VisualOdometry> odometry = Make();
  ASSERT_NE(odometry, nullptr);
  const cv::Mat texture = RandomTexture(1400, 480, 11);
  const int shift = 5;
  const double depth = 2.0;
  for (int k = 0; k < 12; ++k) {
    absl::StatusOr<FrameResult> result = odometry->ProcessFrame(SlidingFrame(texture, k, shift, depth));
    ASSERT_TRUE(result.ok()) << result.status();
    if (k == 0) {
      EXPECT_EQ(result->state, TrackingState::kInitializing);
      EXPECT_TRUE(result->keyframe);
      continue;
    }
    EXPECT_EQ(result->state, TrackingState::kTracking) << "frame " << k;
    EXPECT_GT(result->counts.tracked, 100) << "frame " << k;
    const double expected_x = k * shift * depth / 500.0;
    EXPECT_NEAR(result->pose.t.x(), expected_x, 0.01) << "frame " << k;
    EXPECT_NEAR(result->pose.t.y(), 0, 0.01) << "frame " << k;
    EXPECT_NEAR(result->pose.t.z(), 0, 0.02) << "frame " << k;
    EXPECT_LT(Eigen::AngleAxisd(result->pose.R).angle(), 0.01) << "frame " << k;
  }
}

// A checkpoint keeps the map: a session restored from SerializeState answers the next frame exactly
// as the one that went on; bytes that are not a state are refused and change nothing.
TEST(VisualOdometryTest, ASavedStateResumesTrackingWithItsMap) {
  const cv::Mat texture = RandomTexture(1400, 480, 13);
  VisualOdometryOptions options;
  options.relocalization_keyframes = 10;  // the archive travels too
  options.bundle_wait = true;             // deterministic adjustments
  for (const auto& [with_depth, bundle_window] :
       std::vector<std::pair<bool, int>>{{true, 0}, {false, 0}, {true, 4}, {false, 6}}) {
    SCOPED_TRACE(absl::StrCat(with_depth ? "RGB-D" : "monocular", ", bundle window ",
                              bundle_window));
    options.bundle_window = bundle_window;  // its keyframes and points travel too
    const auto frame = [&](int k) {
      FrameInput f = SlidingFrame(texture, k, 5, 2.0);
      if (!with_depth) f.depth = cv::Mat();
      return f;
    };
    std::unique_ptr<VisualOdometry> original = Make(options);
    ASSERT_NE(original, nullptr);
    for (int k = 0; k < 30; ++k) ASSERT_TRUE(original->ProcessFrame(frame(k)).ok());
    const std::string state = original->SerializeState();

    std::unique_ptr<VisualOdometry> restored = Make(options);
    ASSERT_NE(restored, nullptr);
    ASSERT_TRUE(restored->RestoreState(state).ok());
    EXPECT_TRUE(restored->SerializeState() == state) << "a restored map saves to the same bytes";
    absl::StatusOr<FrameResult> went_on = original->ProcessFrame(frame(30));
    absl::StatusOr<FrameResult> resumed = restored->ProcessFrame(frame(30));
    ASSERT_TRUE(went_on.ok() && resumed.ok());
    EXPECT_EQ(resumed->state, TrackingState::kTracking);
    EXPECT_EQ(resumed->counts.tracked, went_on->counts.tracked);
    EXPECT_NEAR((resumed->pose.t - went_on->pose.t).norm(), 0, 1e-12);
    if (bundle_window > 0) {
      // The window goes on adjusting: a few more frames give the same answers as the original's.
      for (int k = 31; k < 36; ++k) {
        went_on = original->ProcessFrame(frame(k));
        resumed = restored->ProcessFrame(frame(k));
        ASSERT_TRUE(went_on.ok() && resumed.ok());
        EXPECT_NEAR((resumed->pose.t - went_on->pose.t).norm(), 0, 1e-9) << "frame " << k;
      }
    }
    // A stamp before the saved one is still refused: time order survives too.
    EXPECT_EQ(restored->ProcessFrame(frame(2)).status().code(),
              absl::StatusCode::kInvalidArgument);
  }

  const std::string state = [&] {
    std::unique_ptr<VisualOdometry> odometry = Make(options);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(odometry->ProcessFrame(SlidingFrame(texture, k, 5, 2.0)).ok());
    return odometry->SerializeState();
  }();
  std::unique_ptr<VisualOdometry> fresh = Make(options);
  ASSERT_NE(fresh, nullptr);
  EXPECT_EQ(fresh->RestoreState(state.substr(0, state.size() / 2)).code(),
            absl::StatusCode::kDataLoss);
  EXPECT_EQ(fresh->RestoreState("not a state").code(), absl::StatusCode::kDataLoss);
  std::string flipped = state;
  flipped[0] ^= 0x5a;
  EXPECT_EQ(fresh->RestoreState(flipped).code(), absl::StatusCode::kDataLoss);
  absl::StatusOr<FrameResult> first = fresh->ProcessFrame(SlidingFrame(texture, 0, 5, 2.0));
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->state, TrackingState::kInitializing);  // unchanged by the refusals
}

// A forced loss: the camera slides along the wall, sees nothing but grey for eight frames (every
// keyframe of the local map is pushed out by the lost frames' empty ones), then looks at the wall
// again from where it was at frame 3. With relocalisation it finds itself against a keyframe it
// had made there; without (the paper) it goes on from its constant-velocity guess. Monocular
// sessions relocalise against the frames they archived, at the session's own scale.
TEST(VisualOdometryTest, RelocalisesAgainstAnOldKeyframeAfterAForcedLoss) {
  const cv::Mat texture = RandomTexture(1400, 480, 12);
  const int shift = 5;
  const double depth = 2.0;
  for (const bool with_depth : {true, false}) {
    SCOPED_TRACE(with_depth ? "RGB-D" : "monocular");
    Pose seen_before;  // the session's own pose of frame 3
    const auto run = [&](int relocalization_keyframes) {
      VisualOdometryOptions options;
      options.relocalization_keyframes = relocalization_keyframes;
      std::unique_ptr<VisualOdometry> odometry = Make(options);
      EXPECT_NE(odometry, nullptr);
      const auto frame = [&](int k) {
        FrameInput f = SlidingFrame(texture, k, shift, depth);
        if (!with_depth) f.depth = cv::Mat();
        return f;
      };
      double stamp = 0;
      for (int k = 0; k < 12; ++k) {
        FrameInput f = frame(k);
        stamp = f.stamp;
        absl::StatusOr<FrameResult> tracked = odometry->ProcessFrame(f);
        EXPECT_TRUE(tracked.ok());
        if (tracked.ok() && k == 3) seen_before = tracked->pose;
      }
      for (int k = 0; k < 8; ++k) {
        FrameInput blank = frame(0);
        blank.image = cv::Mat(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
        blank.stamp = stamp += 0.1;
        absl::StatusOr<FrameResult> lost = odometry->ProcessFrame(blank);
        EXPECT_TRUE(lost.ok());
        if (lost.ok()) EXPECT_EQ(lost->state, TrackingState::kLost);
      }
      FrameInput back = frame(3);
      back.stamp = stamp + 0.1;
      absl::StatusOr<FrameResult> result = odometry->ProcessFrame(back);
      EXPECT_TRUE(result.ok()) << result.status();
      return result.ok() ? *result : FrameResult{};
    };
    const FrameResult found = run(50);
    EXPECT_TRUE(found.relocalized);
    EXPECT_EQ(found.state, TrackingState::kTracking);
    // Where the session had put frame 3 (RGB-D: also the truth, 0.06 m along x).
    const double mono_step = seen_before.t.norm() / 3;  // a frame's step at the session's scale
    if (with_depth) EXPECT_NEAR(seen_before.t.x(), 3 * shift * depth / 500.0, 0.01);
    EXPECT_LT((found.pose.t - seen_before.t).norm(), with_depth ? 0.02 : 0.3 * mono_step);

    const FrameResult paper = run(0);
    EXPECT_FALSE(paper.relocalized);
    EXPECT_EQ(paper.state, TrackingState::kLost);
    // The guess ran on: more than 10 cm (RGB-D), more than five frames' steps (monocular).
    EXPECT_GT((paper.pose.t - seen_before.t).norm(), with_depth ? 0.1 : 5 * mono_step);
  }
}

// The camera pans about its y axis by `degrees_per_frame` in front of a wall at depth 2 m: each
// frame is the first one warped by the homography K R K^-1, and its depth comes from the wall.
FrameInput PanningFrame(const cv::Mat& texture, int k, double degrees_per_frame,
                        Eigen::Matrix3d* rotation) {
  const CameraModel c = SyntheticCamera();
  Eigen::Matrix3d K;
  K << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1;
  // X_k = R X_0: the world (first camera) seen from camera k.
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(k * degrees_per_frame * M_PI / 180, Eigen::Vector3d::UnitY()).matrix();
  *rotation = R;
  const Eigen::Matrix3d H = K * R * K.inverse();  // pixel of frame 0 -> pixel of frame k
  cv::Mat h(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) h.at<double>(r, col) = H(r, col);
  FrameInput frame;
  frame.stamp = 0.1 * k;
  const cv::Mat center = texture(cv::Rect((texture.cols - 640) / 2, 0, 640, 480));
  // The wall is wider than the view: warp the wide texture with the centre crop's offset.
  cv::Mat shift = (cv::Mat_<double>(3, 3) << 1, 0, -(texture.cols - 640) / 2.0, 0, 1, 0, 0, 0, 1);
  cv::warpPerspective(texture, frame.image, h * shift, cv::Size(640, 480));
  (void)center;
  frame.depth = cv::Mat(480, 640, CV_16UC1);
  const Eigen::Matrix3d Kinv = K.inverse();
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d d = Kinv * Eigen::Vector3d(u, v, 1);
      const double lambda = 2.0 / (R.transpose() * d).z();
      frame.depth.at<uint16_t>(v, u) = static_cast<uint16_t>(lambda * d.z() * 5000);
    }
  }
  return frame;
}

TEST(VisualOdometryTest, RecoversAKnownPanWithDepth) {
  std::unique_ptr<VisualOdometry> odometry = Make();
  ASSERT_NE(odometry, nullptr);
  const cv::Mat texture = RandomTexture(1400, 480, 13);
  for (int k = 0; k < 10; ++k) {
    Eigen::Matrix3d R;
    absl::StatusOr<FrameResult> result = odometry->ProcessFrame(PanningFrame(texture, k, 1.0, &R));
    ASSERT_TRUE(result.ok()) << result.status();
    if (k == 0) continue;
    EXPECT_EQ(result->state, TrackingState::kTracking) << "frame " << k;
    // The pose is camera -> world: the inverse of the world -> camera rotation R.
    EXPECT_LT(Eigen::AngleAxisd(result->pose.R * R).angle(), 0.006) << "frame " << k;
    EXPECT_LT(result->pose.t.norm(), 0.01) << "frame " << k;
  }
}

// A textured "person" patch pasted over the wall moves against the camera motion inside a box
// the robot supplies: the full method labels its features dynamic and keeps the pose right.
TEST(VisualOdometryTest, FullFilterDropsAMovingObjectInABox) {
  std::unique_ptr<VisualOdometry> odometry = Make();
  ASSERT_NE(odometry, nullptr);
  const cv::Mat wall = RandomTexture(1400, 480, 21);
  const cv::Mat person = RandomTexture(160, 300, 99);
  const int shift = 5;
  int dynamic = 0;
  for (int k = 0; k < 10; ++k) {
    FrameInput frame = SlidingFrame(wall, k, shift, 2.0);
    // The person walks right by 12 px per frame in the image, at the wall's depth.
    const cv::Rect where(200 + 12 * k, 100, person.cols, person.rows);
    person.copyTo(frame.image(where));
    frame.boxes = std::vector<Box>{{static_cast<float>(where.x - 5), 95.f,
                                    static_cast<float>(where.width + 10), 310.f, "person", 0.9f}};
    absl::StatusOr<FrameResult> result = odometry->ProcessFrame(frame);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_GT(result->counts.potentially_dynamic, 0);
    if (k == 0) continue;
    dynamic += result->counts.dynamic;
    EXPECT_EQ(result->state, TrackingState::kTracking);
    EXPECT_NEAR(result->pose.t.x(), k * shift * 2.0 / 500.0, 0.01) << "frame " << k;
    for (size_t i = 0; i < result->keypoints.size(); ++i) {
      const cv::Point2f& p = result->keypoints[i];
      const bool on_person = where.contains(cv::Point(p)) && p.x > where.x + 4 &&
                             p.x < where.x + where.width - 4 && p.y > 104 && p.y < 396;
      if (on_person) {
        EXPECT_NE(result->labels[i], FeatureLabel::kStatic) << "frame " << k << " at " << p;
        EXPECT_NE(result->labels[i], FeatureLabel::kStaticInBox) << "frame " << k << " at " << p;
      }
    }
  }
  EXPECT_GT(dynamic, 20);
}

// A parked "car" (a box over part of the wall, moving with it) and a "person" (a patch walking
// down, across the epipolar lines of the sideways camera) in boxes, monocular (every frame a
// keyframe). The proven filter maps the car's features once they have been static for 2 frames;
// the person's never, and the paper's full filter none at all.
TEST(VisualOdometryTest, ProvenFilterMapsAStaticBoxedObjectButNotAMovingOne) {
  const cv::Mat wall = RandomTexture(1400, 480, 23);
  const cv::Mat person = RandomTexture(120, 160, 98);
  const int shift = 5;
  const auto run = [&](DynamicFilter filter, bool with_car) {
    VisualOdometryOptions options;
    options.filter = filter;
    options.proven_static_frames = 2;
    std::unique_ptr<VisualOdometry> odometry = Make(options);
    EXPECT_NE(odometry, nullptr);
    int proven = 0;
    for (int k = 0; k < 12 && odometry != nullptr; ++k) {
      FrameInput frame = SlidingFrame(wall, k, shift, 2.0);
      frame.depth = cv::Mat();
      const cv::Rect walking(420, 20 + 10 * k, person.cols, person.rows);
      person.copyTo(frame.image(walking));
      std::vector<Box> boxes = {{static_cast<float>(walking.x - 5),
                                 static_cast<float>(walking.y - 5),
                                 static_cast<float>(walking.width + 10),
                                 static_cast<float>(walking.height + 10), "person", 0.9f}};
      // The car is part of the wall: its box slides with the wall's image.
      if (with_car) boxes.push_back({60.f - shift * k, 120.f, 220.f, 200.f, "car", 0.9f});
      frame.boxes = boxes;
      absl::StatusOr<FrameResult> result = odometry->ProcessFrame(frame);
      EXPECT_TRUE(result.ok()) << result.status();
      if (!result.ok()) break;
      if (k > 0) EXPECT_EQ(result->state, TrackingState::kTracking) << "frame " << k;
      proven += result->counts.proven;
    }
    return proven;
  };
  const int car = run(DynamicFilter::kProven, /*with_car=*/true);
  const int person_only = run(DynamicFilter::kProven, /*with_car=*/false);
  const int paper = run(DynamicFilter::kFull, /*with_car=*/true);
  std::printf("proven boxed features over 12 frames: car and person %d, person only %d, paper %d\n",
              car, person_only, paper);
  EXPECT_GT(car, 100);          // the car's features, mapped frame after frame
  EXPECT_LT(person_only, 10);   // a stray corner at the box's edge at most
  EXPECT_EQ(paper, 0);
}

TEST(VisualOdometryTest, ResetAtContinuesFromTheGivenPose) {
  std::unique_ptr<VisualOdometry> odometry = Make();
  ASSERT_NE(odometry, nullptr);
  const cv::Mat texture = RandomTexture(1400, 480, 5);
  TimedPose start;
  start.stamp = -1;
  start.pose.t = Eigen::Vector3d(1, 2, 3);
  odometry->ResetAt(start);
  absl::StatusOr<FrameResult> first = odometry->ProcessFrame(SlidingFrame(texture, 0, 5, 2.0));
  ASSERT_TRUE(first.ok());
  EXPECT_TRUE(first->keyframe);
  EXPECT_NEAR((first->pose.t - start.pose.t).norm(), 0, 1e-9);
  absl::StatusOr<FrameResult> second = odometry->ProcessFrame(SlidingFrame(texture, 1, 5, 2.0));
  ASSERT_TRUE(second.ok());
  EXPECT_NEAR(second->pose.t.x(), 1 + 5 * 2.0 / 500, 0.01);
}

// ATE floors set from measurement (docs/visual-odometry.md); they catch a broken pipeline, not
// small regressions. Skipped without ../shared.
// One run over a real window: RGB-D windows are scored rigidly, monocular ones with scale.
testing::RunSummary RunWindow(const cli::ImageSequence& sequence, const std::string& preset,
                              const VisualOdometryOptions& options, bool detector, bool depth) {
  absl::StatusOr<std::unique_ptr<VisualOdometry>> odometry =
      VisualOdometry::Create(options, testing::SequenceCamera(sequence, preset),
                             detector ? testing::SharedYolo() : nullptr);
  EXPECT_TRUE(odometry.ok()) << odometry.status();
  if (!odometry.ok()) return {};
  return testing::RunAndEvaluate(**odometry, sequence, /*with_depth=*/depth,
                                 /*with_scale=*/!depth);
}

// The paper's tables are checked on the paper's preset, explicitly: the service's default is the
// measured best (VisualOdometryOptions::MeasuredBest), not the paper.
testing::RunSummary RunBonn(const cli::ImageSequence& bonn, DynamicFilter filter, bool detector) {
  VisualOdometryOptions options = VisualOdometryOptions::Paper();
  options.filter = filter;
  return RunWindow(bonn, "bonn", options, detector, /*depth=*/true);
}

TEST(RealSequenceTest, BonnCrowdWindowRgbd) {
  const std::optional<cli::ImageSequence> bonn = testing::BonnSequence();
  if (!bonn) GTEST_SKIP() << "../shared/data/vslam not present";
  const testing::RunSummary plain = RunBonn(*bonn, DynamicFilter::kNone, false);
  const testing::RunSummary full = RunBonn(*bonn, DynamicFilter::kFull, true);
  std::printf("bonn crowd 140 frames RGB-D: plain ORB ate %.4f m (lost %d), full method ate %.4f m "
              "(lost %d, %d potentially dynamic, %d dynamic)\n",
              plain.ate_rmse, plain.lost, full.ate_rmse, full.lost, full.potentially_dynamic,
              full.dynamic);
  EXPECT_EQ(full.frames, 140);
  EXPECT_GT(full.potentially_dynamic, 1000);  // people are in most frames
  EXPECT_LT(full.ate_rmse, 0.10);             // measured 0.023 m (seed 1); plain ORB 0.17 m
  EXPECT_GT(plain.ate_rmse, 2 * full.ate_rmse);
}

// Intrinsics that are valid but wrong (a focal length 30 % too long, distortion ignored: a robot
// configured with another camera's calibration) must not break the session: every frame is
// answered, and the error shows up as accuracy, not as a crash or a rejection.
TEST(RealSequenceTest, WrongIntrinsicsStillAnswerEveryFrame) {
  const std::optional<cli::ImageSequence> bonn = testing::BonnSequence();
  if (!bonn) GTEST_SKIP() << "../shared/data/vslam not present";
  CameraModel wrong = testing::SequenceCamera(*bonn, "bonn");
  wrong.fx *= 1.3;
  wrong.fy *= 1.3;
  wrong.distortion = {};
  std::unique_ptr<VisualOdometry> odometry = Make({}, wrong);
  ASSERT_NE(odometry, nullptr);
  const testing::RunSummary summary =
      testing::RunAndEvaluate(*odometry, *bonn, /*with_depth=*/true, /*with_scale=*/false);
  std::printf("bonn with wrong intrinsics (no detector): ate %.4f m, lost %d\n", summary.ate_rmse,
              summary.lost);
  EXPECT_EQ(summary.frames, 140);
  EXPECT_EQ(odometry->trajectory().size(), 140u);
}

TEST(RealSequenceTest, KittiMonocular) {
  const std::optional<cli::ImageSequence> kitti = testing::KittiSequence();
  if (!kitti) GTEST_SKIP() << "../shared/data/vslam not present";
  std::unique_ptr<VisualOdometry> odometry =
      Make(VisualOdometryOptions::Paper(), testing::SequenceCamera(*kitti, ""));
  ASSERT_NE(odometry, nullptr);
  testing::RunSummary summary =
      testing::RunAndEvaluate(*odometry, *kitti, /*with_depth=*/false, /*with_scale=*/true);
  std::printf("kitti mono: frames %d lost %d ate %.4f m (Sim3)\n", summary.frames, summary.lost,
              summary.ate_rmse);
  EXPECT_EQ(summary.frames, 51);
  EXPECT_LT(summary.ate_rmse, 4.0);  // measured 2.81 m over the 60 m drive (Sim(3)), seed 1
}

// Beyond the paper on the same window, the configuration docs/visual-odometry.md recommends:
// the proven-static filter without eq 17's Hamming half, the monocular motion prior and a local
// bundle adjustment (applied before the next frame, so the run is deterministic). Seed 1
// measured: the paper's full method 4.19-5.08 m; the recommended one 0.855 m, plain ORB with the
// same additions 0.775 m (5 seeds: 0.81 against 0.83).
testing::RunSummary RunKitti(const cli::ImageSequence& kitti, DynamicFilter filter,
                             VisualOdometryOptions options) {
  options.filter = filter;
  return RunWindow(kitti, "", options, /*detector=*/filter != DynamicFilter::kNone,
                   /*depth=*/false);
}

TEST(RealSequenceTest, KittiProvenFilterKeepsTheParkedCarsAndMatchesPlain) {
  const std::optional<cli::ImageSequence> kitti = testing::KittiSequence();
  if (!kitti) GTEST_SKIP() << "../shared/data/vslam not present";
  if (testing::SharedYolo() == nullptr) GTEST_SKIP() << "../shared/models not present";
  const testing::RunSummary paper =
      RunKitti(*kitti, DynamicFilter::kFull, VisualOdometryOptions::Paper());
  VisualOdometryOptions best = VisualOdometryOptions::MeasuredBest();  // the service's default
  best.bundle_wait = true;
  const testing::RunSummary proven = RunKitti(*kitti, DynamicFilter::kProven, best);
  const testing::RunSummary again = RunKitti(*kitti, DynamicFilter::kProven, best);
  const testing::RunSummary plain = RunKitti(*kitti, DynamicFilter::kNone, best);
  std::printf("kitti: paper's full method %.3f m; proven + prior + bundle adjustment %.3f m; "
              "plain with the same %.3f m (Sim3)\n",
              paper.ate_rmse, proven.ate_rmse, plain.ate_rmse);
  EXPECT_EQ(proven.frames, 51);
  EXPECT_LT(proven.ate_rmse, 1.5);  // the target for the dynamic filter
  EXPECT_LT(proven.ate_rmse, 0.5 * paper.ate_rmse);
  EXPECT_LT(proven.ate_rmse, 1.25 * plain.ate_rmse);  // no real loss where the cars are parked
  EXPECT_EQ(again.ate_rmse, proven.ate_rmse);  // bundle_wait: the same answers every run
}

}  // namespace
}  // namespace waymark::visual_slam

namespace waymark::visual_slam {
namespace {

// Issue 35: the measured best runs its bundle adjustment on monocular sessions only; an RGB-D
// session (depth in its first frame) takes none. Each tracked answer carries its quality.
TEST(PresetAndEstimateQualityTest, MeasuredBestIsPerInputKindAndAnswersCarryQuality) {
  const VisualOdometryOptions paper = VisualOdometryOptions::Paper();
  EXPECT_EQ(paper.filter, DynamicFilter::kFull);
  EXPECT_EQ(paper.static_hamming_fraction, 0.5);
  EXPECT_EQ(paper.bundle_window, 0);
  EXPECT_FALSE(paper.join_static_boxed);
  const VisualOdometryOptions best = OptionsForPreset(Preset::kMeasuredBest);
  EXPECT_EQ(best.filter, DynamicFilter::kProven);
  EXPECT_TRUE(best.join_static_boxed);
  EXPECT_EQ(best.bundle_window, 10);
  EXPECT_TRUE(best.bundle_monocular_only);

  std::unique_ptr<VisualOdometry> odometry = Make(best);
  ASSERT_NE(odometry, nullptr);
  const cv::Mat texture = RandomTexture(1400, 480, 11);
  for (int k = 0; k < 4; ++k) {
    absl::StatusOr<FrameResult> result = odometry->ProcessFrame(SlidingFrame(texture, k, 5, 2.0));
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_TRUE(result->warnings.empty());  // the synthetic camera fits its images
    if (k == 0) {
      EXPECT_EQ(result->quality.level, TrackingQuality::Level::kInitializing);
      continue;
    }
    EXPECT_EQ(result->quality.level, TrackingQuality::Level::kGood) << result->quality.reason;
    EXPECT_GT(result->quality.inliers, 100);
    EXPECT_GT(result->quality.parallax_deg, 0.0);
  }
  EXPECT_EQ(odometry->options().bundle_window, 0);  // RGB-D: no adjustment

  // Monocular, standing still: no parallax. Never GOOD: the sampler finds no motion (LOST) or a
  // motion without parallax (WEAK), and the answer says why.
  std::unique_ptr<VisualOdometry> mono = Make(best);
  ASSERT_NE(mono, nullptr);
  TrackingQuality last;
  for (int k = 0; k < 4; ++k) {
    FrameInput frame = SlidingFrame(texture, 0, 0, 2.0);
    frame.stamp = 0.1 * k;
    frame.depth = cv::Mat();
    absl::StatusOr<FrameResult> result = mono->ProcessFrame(frame);
    ASSERT_TRUE(result.ok()) << result.status();
    last = result->quality;
  }
  EXPECT_EQ(mono->options().bundle_window, 10);  // monocular keeps it
  EXPECT_NE(last.level, TrackingQuality::Level::kGood);
  EXPECT_LT(last.parallax_deg, kLowParallaxDeg);
  EXPECT_FALSE(last.reason.empty());
}

// Issue 35: `vo run <Bonn folder> --camera kitti` ran silently. Intrinsics that do not fit the
// images warn on the session's first answer.
TEST(PresetAndEstimateQualityTest, IntrinsicsThatDoNotFitTheImagesWarn) {
  CameraModel bonn{542.822841, 542.576870, 315.593520, 237.756098, {}, 640, 480};
  EXPECT_TRUE(CameraWarnings(bonn).empty());
  CameraModel kitti{707.0912, 707.0912, 601.8873, 183.1104, {}, 1226, 370};
  EXPECT_TRUE(CameraWarnings(kitti).empty());
  CameraModel kitti_on_bonn = kitti;
  kitti_on_bonn.width = 640;
  kitti_on_bonn.height = 480;
  const std::vector<std::string> warnings = CameraWarnings(kitti_on_bonn);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("principal point"), std::string::npos) << warnings[0];
  CameraModel outside = bonn;
  outside.cx = 700;
  EXPECT_NE(CameraWarnings(outside).at(0).find("outside"), std::string::npos);
  CameraModel tele = bonn;
  tele.fx = tele.fy = 5000;
  ASSERT_EQ(CameraWarnings(tele).size(), 2u);  // fx and fy
  EXPECT_NE(CameraWarnings(tele)[0].find("implausible"), std::string::npos);

  CameraModel synthetic = SyntheticCamera();
  synthetic.cx = 600;  // far from the centre of 640 x 480
  std::unique_ptr<VisualOdometry> odometry = Make({}, synthetic);
  ASSERT_NE(odometry, nullptr);
  const cv::Mat texture = RandomTexture(1400, 480, 11);
  absl::StatusOr<FrameResult> first = odometry->ProcessFrame(SlidingFrame(texture, 0, 5, 2.0));
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(first->warnings.size(), 1u);
  absl::StatusOr<FrameResult> second = odometry->ProcessFrame(SlidingFrame(texture, 1, 5, 2.0));
  ASSERT_TRUE(second.ok());
  EXPECT_TRUE(second->warnings.empty());  // once per session
}

}  // namespace
}  // namespace waymark::visual_slam
