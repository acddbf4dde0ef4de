// Issue 35: EuRoC MAV / ASL folders as an image-sequence layout for `vo run`, and EuRoC's ground
// truth for `eval ate`. No EuRoC data in ../shared: a small synthetic folder is written here.

#include "client/datasets/euroc.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>

#include "client/datasets/image_sequence.h"
#include "client/datasets/pose_file.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;

constexpr char kSensorYaml[] = R"(# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)";

constexpr char kGroundTruth[] =
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
    "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
    "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
    "b_a_RS_S_z [m s^-2]\n"
    "1403636579758555392,4.688319,-1.786938,0.783338,0.534108,-0.153029,-0.827383,-0.082152,"
    "-0.027876,0.033207,0.800006,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n"
    "1403636579763555584,4.688177,-1.786770,0.787350,0.534640,-0.152990,-0.826976,-0.082863,"
    "-0.029272,0.033992,0.804771,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n"
    "1403636579813555456,4.686550,-1.784930,0.827300,0.538130,-0.151980,-0.824900,-0.085700,"
    "-0.030000,0.035000,0.810000,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n";

// mav0/ with three 752 x 480 frames, sensor.yaml and the ground truth.
fs::path WriteEuroc(const testing::ScopedTempDir& dir) {
  const fs::path cam = dir.Make("MH_01/mav0/cam0/data/x").parent_path().parent_path();
  std::ofstream(cam / "sensor.yaml") << kSensorYaml;
  std::ofstream csv(cam / "data.csv");
  csv << "#timestamp [ns],filename\n";
  for (const char* stamp : {"1403636579763555584", "1403636579813555456", "1403636579863555584"}) {
    csv << stamp << "," << stamp << ".png\n";
    testing::WriteImage(cam / "data" / (std::string(stamp) + ".png"), 752, 480,
                        cv::Scalar(40 + stamp[17]));
  }
  csv.close();
  std::ofstream(dir.Make("MH_01/mav0/state_groundtruth_estimate0/data.csv")) << kGroundTruth;
  return dir.path() / "MH_01";
}

TEST(EurocTest, CreatesAnImageSequenceFromTheFolder) {
  testing::ScopedTempDir dir;
  const fs::path folder = WriteEuroc(dir);
  for (const fs::path& given : {folder, folder / "mav0"}) {
    absl::StatusOr<ImageSequence> sequence = ReadImageSequence(given);
    ASSERT_TRUE(sequence.ok()) << sequence.status();
    EXPECT_EQ(sequence->layout, SequenceLayout::kEuroc);
    EXPECT_STREQ(SequenceLayoutName(sequence->layout), "euroc");
    ASSERT_EQ(sequence->frames.size(), 3u);
    EXPECT_NEAR(sequence->frames[0].stamp, 1403636579.763555584, 1e-6);
    EXPECT_NEAR(sequence->frames[1].stamp - sequence->frames[0].stamp, 0.05, 1e-6);
    EXPECT_FALSE(sequence->frames[0].depth);
    ASSERT_TRUE(sequence->intrinsics);
    EXPECT_DOUBLE_EQ(sequence->intrinsics->fx, 458.654);
    EXPECT_DOUBLE_EQ(sequence->intrinsics->cy, 248.375);
    EXPECT_DOUBLE_EQ(sequence->intrinsics->distortion[0], -0.28340811);
    EXPECT_DOUBLE_EQ(sequence->intrinsics->distortion[3], 1.76187114e-05);
    EXPECT_DOUBLE_EQ(sequence->intrinsics->distortion[4], 0);
    ASSERT_TRUE(sequence->groundtruth);
  }
}

TEST(EurocTest, GroundTruthTranslatesTheBodyToTheCamera) {
  testing::ScopedTempDir dir;
  absl::StatusOr<ImageSequence> sequence = ReadImageSequence(WriteEuroc(dir));
  ASSERT_TRUE(sequence.ok()) << sequence.status();
  absl::StatusOr<std::vector<StampedPose3>> truth = ReadSequenceGroundTruth(*sequence);
  ASSERT_TRUE(truth.ok()) << truth.status();
  ASSERT_EQ(truth->size(), 3u);
  // body pose * T_BS: the camera sits (-0.0216, -0.0647, 0.0098) m from the body.
  const Eigen::Quaterniond q_body(0.534108, -0.153029, -0.827383, -0.082152);
  const Eigen::Vector3d expected =
      Eigen::Vector3d(4.688319, -1.786938, 0.783338) +
      q_body.normalized() * Eigen::Vector3d(-0.0216401454975, -0.064676986768, 0.00981073058949);
  EXPECT_NEAR(((*truth)[0].translation - expected).norm(), 0, 1e-6);
  EXPECT_NEAR((*truth)[0].stamp, 1403636579.758555392, 1e-6);
}

TEST(EurocTest, EvalAteValidatesTheGroundTruthCsv) {
  absl::StatusOr<PoseFormat> format = DetectPoseFormat(kGroundTruth);
  ASSERT_TRUE(format.ok()) << format.status();
  EXPECT_EQ(*format, PoseFormat::kEuroc);
  absl::StatusOr<PoseFile> file = ParsePoseText(kGroundTruth);
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(file->format, PoseFormat::kEuroc);
  ASSERT_EQ(file->poses.size(), 3u);
  EXPECT_DOUBLE_EQ(file->poses[1].translation.z(), 0.787350);
  EXPECT_EQ(*ParsePoseFormat("euroc"), PoseFormat::kEuroc);
  // TUM lines with the same first columns are not mistaken for EuRoC.
  EXPECT_EQ(*DetectPoseFormat("1.0 0 0 0 0 0 0 1\n"), PoseFormat::kTum);
  // A quaternion in TUM order (w last) in a EuRoC file is refused with the expected order.
  absl::StatusOr<PoseFile> bad = ParsePoseText("1403636579758555392,1,2,3,0,0,0,0.2\n");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("q_w"), std::string::npos) << bad.status();
}

TEST(EurocTest, RefusesInaccurateFolders) {
  EXPECT_FALSE(ParseEurocSensorYaml("camera_model: omni\nintrinsics: [1, 1, 1, 1]\n").ok());
  EXPECT_FALSE(ParseEurocSensorYaml("distortion_model: equidistant\n"
                                    "intrinsics: [400, 400, 300, 200]\n"
                                    "distortion_coefficients: [0.1, 0.2, 0.3, 0.4]\n")
                   .ok());
  EXPECT_FALSE(ParseEurocSensorYaml("resolution: [752, 480]\n").ok());  // no intrinsics
  testing::ScopedTempDir dir;
  const fs::path folder = WriteEuroc(dir);
  fs::remove(folder / "mav0/cam0/data/1403636579813555456.png");
  absl::StatusOr<ImageSequence> sequence = ReadImageSequence(folder);
  ASSERT_FALSE(sequence.ok());
  EXPECT_NE(sequence.status().message().find("1403636579813555456.png"), std::string::npos);
}

}  // namespace
}  // namespace waymark::cli
