// Image sequence readers for `waymark vo run` (image_sequence.h): TUM and KITTI layouts on small
// temporary folders, their errors, camera presets, and the two real layouts in
// ../shared/data/vslam (skipped when absent).
#include "client/datasets/image_sequence.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "client/datasets/kitti_stamps.h"
#include "client/datasets/pose_file.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::ScopedTempDir;
namespace fs = std::filesystem;

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path);
  out << text;
}

// Empty files stand in for images: the reader checks that they exist, not what they hold.
void Touch(const ScopedTempDir& dir, const std::string& relative) {
  WriteText(dir.Make(relative), "");
}

TEST(ImageSequenceTest, TumRgbListPairsDepthByStamp) {
  ScopedTempDir dir;
  for (const char* f :
       {"rgb/1.000.png", "rgb/1.033.png", "rgb/1.066.png", "depth/1.001.png", "depth/1.070.png"}) {
    Touch(dir, f);
  }
  WriteText(dir.path() / "rgb.txt",
            "# color images\n# timestamp filename\n1.000 rgb/1.000.png\n1.033 rgb/1.033.png\n\n"
            "1.066 rgb/1.066.png\n");
  WriteText(dir.path() / "depth.txt", "# depth\n1.001 depth/1.001.png\n1.070 depth/1.070.png\n");
  WriteText(dir.path() / "groundtruth.txt", "1.0 0 0 0 0 0 0 1\n");

  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->layout, SequenceLayout::kTum);
  ASSERT_EQ(seq->frames.size(), 3u);
  EXPECT_DOUBLE_EQ(seq->frames[1].stamp, 1.033);
  EXPECT_EQ(seq->frames[1].image, dir.path() / "rgb/1.033.png");
  ASSERT_TRUE(seq->frames[0].depth.has_value());
  EXPECT_EQ(*seq->frames[0].depth, dir.path() / "depth/1.001.png");
  // 1.033 is 0.032 s from the nearest depth frame: beyond associate.py's 0.02 s.
  EXPECT_FALSE(seq->frames[1].depth.has_value());
  ASSERT_TRUE(seq->frames[2].depth.has_value());
  EXPECT_EQ(*seq->frames[2].depth, dir.path() / "depth/1.070.png");
  EXPECT_TRUE(seq->has_depth_list);
  EXPECT_EQ(seq->frames_without_depth, 1);
  EXPECT_FALSE(seq->intrinsics.has_value());
  ASSERT_TRUE(seq->groundtruth.has_value());
  EXPECT_EQ(*seq->groundtruth, dir.path() / "groundtruth.txt");
}

TEST(ImageSequenceTest, AssociationsTakePrecedence) {
  ScopedTempDir dir;
  for (const char* f : {"rgb/a.png", "rgb/b.png", "depth/a.png", "depth/b.png"}) Touch(dir, f);
  WriteText(dir.path() / "rgb.txt", "this list is not read\n");
  WriteText(dir.path() / "associations.txt",
            "5.0 rgb/a.png 5.004 depth/a.png\n5.1 rgb/b.png 5.103 depth/b.png\n");
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_TRUE(seq.ok()) << seq.status();
  ASSERT_EQ(seq->frames.size(), 2u);
  EXPECT_DOUBLE_EQ(seq->frames[1].stamp, 5.1);
  EXPECT_EQ(*seq->frames[1].depth, dir.path() / "depth/b.png");
  EXPECT_EQ(seq->frames_without_depth, 0);
  EXPECT_FALSE(seq->groundtruth.has_value());
}

TEST(ImageSequenceTest, TumErrorsNameFileAndLine) {
  ScopedTempDir dir;
  Touch(dir, "rgb/a.png");
  WriteText(dir.path() / "rgb.txt", "# header\n1.0 rgb/a.png\n2.0 rgb/missing.png\n");
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(seq.status().message(), HasSubstr("rgb.txt line 3"));
  EXPECT_THAT(seq.status().message(), HasSubstr("missing.png"));

  WriteText(dir.path() / "rgb.txt", "1.0 rgb/a.png extra\n");
  seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(seq.status().message(), HasSubstr("line 1: 3 fields; expected 2"));

  WriteText(dir.path() / "rgb.txt", "one rgb/a.png\n");
  seq = ReadImageSequence(dir.path());
  EXPECT_THAT(seq.status().message(), HasSubstr("'one' is not a time stamp"));

  Touch(dir, "rgb/b.png");
  WriteText(dir.path() / "rgb.txt", "2.0 rgb/a.png\n1.0 rgb/b.png\n");
  seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(seq.status().message(), HasSubstr("line 2: stamp 1 does not increase"));

  WriteText(dir.path() / "rgb.txt", "# only comments\n");
  seq = ReadImageSequence(dir.path());
  EXPECT_THAT(seq.status().message(), HasSubstr("no frames"));

  WriteText(dir.path() / "associations.txt", "1.0 rgb/a.png 1.0\n");
  seq = ReadImageSequence(dir.path());
  EXPECT_THAT(seq.status().message(), HasSubstr("associations.txt line 1: 3 fields; expected 4"));
  WriteText(dir.path() / "associations.txt", "1.0 rgb/a.png 1.0 depth/none.png\n");
  seq = ReadImageSequence(dir.path());
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(seq.status().message(), HasSubstr("depth/none.png"));
}

TEST(ImageSequenceTest, NeitherLayout) {
  ScopedTempDir dir;
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(seq.status().message(), HasSubstr("rgb.txt or associations.txt"));
  EXPECT_THAT(seq.status().message(), HasSubstr("image_0/"));
  seq = ReadImageSequence(dir.path() / "nope");
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
}

TEST(ImageSequenceTest, KittiWithLabelledCalibAndTimes) {
  ScopedTempDir dir;
  for (const char* f : {"image_0/000001.png", "image_0/000000.png", "image_0/000002.png"}) {
    Touch(dir, f);
  }
  Touch(dir, "image_0/notes.txt");  // not an image: ignored
  WriteText(dir.path() / "calib.txt",
            "P0: 700 0 600 0 0 710 180 0 0 0 1 0\nP1: 700 0 600 -380 0 710 180 0 0 0 1 0\n");
  WriteText(dir.path() / "times.txt", "0.0\n0.105\n0.2\n0.3\n");
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->layout, SequenceLayout::kKitti);
  ASSERT_EQ(seq->frames.size(), 3u);
  EXPECT_EQ(seq->frames[0].image.filename(), "000000.png");
  EXPECT_EQ(seq->frames[2].image.filename(), "000002.png");
  EXPECT_DOUBLE_EQ(seq->frames[1].stamp, 0.105);
  EXPECT_FALSE(seq->frames[1].depth.has_value());
  ASSERT_TRUE(seq->intrinsics.has_value());
  EXPECT_DOUBLE_EQ(seq->intrinsics->fx, 700);
  EXPECT_DOUBLE_EQ(seq->intrinsics->fy, 710);
  EXPECT_DOUBLE_EQ(seq->intrinsics->cx, 600);
  EXPECT_DOUBLE_EQ(seq->intrinsics->cy, 180);
}

TEST(ImageSequenceTest, KittiUnlabelledCalibAndDefaultStamps) {
  ScopedTempDir dir;
  Touch(dir, "image_0/000000.png");
  Touch(dir, "image_0/000001.png");
  // The shared copy's calib.txt: no `P0:` labels, no final newline.
  WriteText(dir.path() / "calib.txt",
            "707 0 601 0 0 707 183 0 0 0 1 0\n707 0 601 -379 0 707 183 0 0 0 1 0");
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_DOUBLE_EQ(seq->frames[0].stamp, 0.0);
  EXPECT_DOUBLE_EQ(seq->frames[1].stamp, 0.1);
  EXPECT_DOUBLE_EQ(seq->intrinsics->cx, 601);
}

TEST(ImageSequenceTest, KittiErrors) {
  ScopedTempDir dir;
  fs::create_directories(dir.path() / "image_0");
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(seq.status().message(), HasSubstr("no .png or .jpg images"));

  Touch(dir, "image_0/000000.png");
  Touch(dir, "image_0/000001.png");
  seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(seq.status().message(), HasSubstr("calib.txt"));

  WriteText(dir.path() / "calib.txt", "P0: 700 0 600 0 0 710 180\n");
  seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(seq.status().message(), HasSubstr("line 1: 7 numbers for P0; expected 12"));

  WriteText(dir.path() / "calib.txt", "P1: 700 0 600 0 0 710 180 0 0 0 1 0\n");
  seq = ReadImageSequence(dir.path());
  EXPECT_THAT(seq.status().message(), HasSubstr("no camera matrix P0"));

  WriteText(dir.path() / "calib.txt", "P0: 700 0 600 0 0 710 180 0 0 0 1 0\n");
  WriteText(dir.path() / "times.txt", "0.0\n");
  seq = ReadImageSequence(dir.path());
  ASSERT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(seq.status().message(), HasSubstr("1 stamps for 2 images"));
}

TEST(ImageSequenceTest, CameraPresetsAndDistortion) {
  absl::StatusOr<CameraIntrinsics> bonn = CameraPreset("bonn");
  ASSERT_TRUE(bonn.ok());
  EXPECT_DOUBLE_EQ(bonn->fx, 542.822841);
  EXPECT_DOUBLE_EQ(bonn->cy, 237.756098);
  EXPECT_DOUBLE_EQ(bonn->distortion[1], -0.099343);
  EXPECT_DOUBLE_EQ(bonn->depth_scale, 5000);
  absl::StatusOr<CameraIntrinsics> tum3 = CameraPreset("tum3");
  ASSERT_TRUE(tum3.ok());
  EXPECT_DOUBLE_EQ(tum3->fy, 539.2);
  EXPECT_DOUBLE_EQ(tum3->distortion[0], 0);
  EXPECT_DOUBLE_EQ(CameraPreset("tum1")->fx, 517.3);
  EXPECT_DOUBLE_EQ(CameraPreset("tum2")->cx, 325.1);
  EXPECT_DOUBLE_EQ(CameraPreset("kitti")->fx, 707.0912);
  absl::StatusOr<CameraIntrinsics> bad = CameraPreset("tum4");
  ASSERT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr("bonn, tum1, tum2, tum3, kitti"));

  absl::StatusOr<std::array<double, 5>> d = ParseDistortion("0.1,-0.2,0.003,0.004");
  ASSERT_TRUE(d.ok());
  EXPECT_DOUBLE_EQ((*d)[1], -0.2);
  EXPECT_DOUBLE_EQ((*d)[4], 0);
  EXPECT_DOUBLE_EQ((*ParseDistortion("1,2,3,4,5"))[4], 5);
  EXPECT_FALSE(ParseDistortion("1,2,3").ok());
  EXPECT_THAT(ParseDistortion("1,2,x,4").status().message(), HasSubstr("'x' is not a number"));
}

TEST(ImageSequenceTest, KittiGroundTruthGetsFrameStamps) {
  ScopedTempDir dir;
  Touch(dir, "image_0/000000.png");
  Touch(dir, "image_0/000001.png");
  WriteText(dir.path() / "calib.txt", "P0: 700 0 600 0 0 710 180 0 0 0 1 0\n");
  WriteText(dir.path() / "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.5 0 1 0 0 0 0 1 1.5\n");
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_TRUE(seq.ok()) << seq.status();
  absl::StatusOr<std::vector<StampedPose3>> gt = ReadSequenceGroundTruth(*seq);
  ASSERT_TRUE(gt.ok()) << gt.status();
  ASSERT_EQ(gt->size(), 2u);
  EXPECT_DOUBLE_EQ((*gt)[1].stamp, 0.1);
  EXPECT_DOUBLE_EQ((*gt)[1].translation.z(), 1.5);
}

// `vo run` stamps the frames with ReadImageSequence's stamps; `eval ate` reads poses.txt with
// ReadPoseFile. Without times.txt both must follow the same rule, or the run's trajectory does
// not match its own ground truth.
TEST(ImageSequenceTest, KittiFramesAndPoseFileShareTheStampRule) {
  ScopedTempDir dir;
  std::string poses;
  for (int i = 0; i < 12; ++i) {
    Touch(dir, fmt::format("image_0/{:06d}.png", i));
    poses += fmt::format("1 0 0 0 0 1 0 0 0 0 1 {}\n", 0.5 * i);
  }
  WriteText(dir.path() / "calib.txt", "P0: 700 0 600 0 0 710 180 0 0 0 1 0\n");
  WriteText(dir.path() / "poses.txt", poses);
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir.path());
  ASSERT_TRUE(seq.ok()) << seq.status();
  absl::StatusOr<PoseFile> file = ReadPoseFile(dir.path() / "poses.txt");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->poses.size(), seq->frames.size());
  for (size_t i = 0; i < seq->frames.size(); ++i) {
    EXPECT_DOUBLE_EQ(file->poses[i].stamp, seq->frames[i].stamp) << "frame " << i;
    EXPECT_DOUBLE_EQ(seq->frames[i].stamp, DefaultKittiStamp(i));
  }
  EXPECT_DOUBLE_EQ(seq->frames[11].stamp, 1.1);  // KITTI's 10 Hz
}

std::string SharedVslam() { return std::string(WAYMARK_SHARED_DIR) + "/data/vslam"; }

TEST(ImageSequenceRealDataTest, BonnCrowdWindow) {
  const fs::path dir = SharedVslam() + "/bonn_rgbd_crowd_frames270-409";
  if (!fs::exists(dir)) GTEST_SKIP() << dir << " not present";
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->layout, SequenceLayout::kTum);
  ASSERT_EQ(seq->frames.size(), 140u);  // SOURCES.md: 140 RGB + 140 depth
  EXPECT_EQ(seq->frames_without_depth, 0);
  EXPECT_DOUBLE_EQ(seq->frames.front().stamp, 1548339828.92438);
  EXPECT_EQ(seq->frames.front().depth->filename(), "1548339828.93123.png");
  EXPECT_FALSE(seq->intrinsics.has_value());
  absl::StatusOr<std::vector<StampedPose3>> gt = ReadSequenceGroundTruth(*seq);
  ASSERT_TRUE(gt.ok()) << gt.status();
  EXPECT_EQ(gt->size(), 933u);  // SOURCES.md: the full sequence's 933 poses
}

TEST(ImageSequenceRealDataTest, KittiSequence06) {
  const fs::path dir = SharedVslam() + "/kitti_odom06_frames000-050";
  if (!fs::exists(dir)) GTEST_SKIP() << dir << " not present";
  absl::StatusOr<ImageSequence> seq = ReadImageSequence(dir);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->layout, SequenceLayout::kKitti);
  ASSERT_EQ(seq->frames.size(), 51u);
  EXPECT_DOUBLE_EQ(seq->frames[50].stamp, 5.0);
  ASSERT_TRUE(seq->intrinsics.has_value());
  EXPECT_DOUBLE_EQ(seq->intrinsics->fx, 707.0912);
  EXPECT_DOUBLE_EQ(seq->intrinsics->cy, 183.1104);
  absl::StatusOr<std::vector<StampedPose3>> gt = ReadSequenceGroundTruth(*seq);
  ASSERT_TRUE(gt.ok()) << gt.status();
  ASSERT_EQ(gt->size(), 51u);
  EXPECT_DOUBLE_EQ((*gt)[1].stamp, 0.1);
  EXPECT_NEAR((*gt)[1].translation.z(), 1.198998, 1e-9);
}

}  // namespace
}  // namespace waymark::cli
