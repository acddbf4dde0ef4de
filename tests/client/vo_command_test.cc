// `waymark vo run` argument and input errors: each is reported before any server is contacted
// (the address below has no server), with a message that says what to fix.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "client/datasets/image_sequence.h"
#include "client/sessions/vo_session.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::CliResult;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;
namespace fs = std::filesystem;

CliResult Vo(std::vector<std::string> args) {
  args.insert(args.begin(), {"vo", "run"});
  return RunWaymark("127.0.0.1:1", std::move(args));
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// A two-frame TUM folder with real 64x48 PNGs and no depth.
class VoCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    waymark::testing::WriteImage(dir_.Make("rgb/1.0.png"), 64, 48, cv::Scalar(10, 20, 30));
    waymark::testing::WriteImage(dir_.Make("rgb/1.1.png"), 64, 48, cv::Scalar(30, 20, 10));
    WriteText(dir_.path() / "rgb.txt", "1.0 rgb/1.0.png\n1.1 rgb/1.1.png\n");
  }
  std::string seq() const { return dir_.path().string(); }
  ScopedTempDir dir_;
};

TEST_F(VoCommandTest, SequenceIsRequired) {
  const CliResult r = Vo({});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err + r.out, HasSubstr("SEQ_DIR"));
}

// The help names every file a run writes (vo_run.cc's "wrote ..." line).
TEST_F(VoCommandTest, HelpListsEveryOutputFile) {
  const CliResult r = RunWaymark("127.0.0.1:1", {"vo", "run", "--help"});
  EXPECT_EQ(r.code, 0) << r.err;
  for (const char* file : {"trajectory.txt", "trajectory.svg", "trajectory.png", "summary.json",
                           "frames/NNNNNN.png"}) {
    EXPECT_THAT(r.out, HasSubstr(file));
  }
}

TEST_F(VoCommandTest, MissingFolder) {
  const CliResult r = Vo({(dir_.path() / "nope").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("NOT_FOUND"));
  EXPECT_THAT(r.err, HasSubstr("no folder"));
}

TEST_F(VoCommandTest, TumWithoutIntrinsicsNamesThePresets) {
  const CliResult r = Vo({seq()});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("no camera calibration"));
  EXPECT_THAT(r.err, HasSubstr("--camera PRESET (bonn, tum1, tum2, tum3, kitti)"));
  const CliResult partial = Vo({seq(), "--fx", "500", "--fy", "500"});
  EXPECT_EQ(partial.code, 1);
  EXPECT_THAT(partial.err, HasSubstr("missing --cx --cy"));
}

TEST_F(VoCommandTest, UnknownPreset) {
  const CliResult r = Vo({seq(), "--camera", "tum9"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("unknown camera 'tum9'"));
}

TEST_F(VoCommandTest, BadFlagValues) {
  EXPECT_NE(Vo({seq(), "--camera", "tum3", "--filter", "most"}).code, 0);
  EXPECT_NE(Vo({seq(), "--camera", "tum3", "--fx", "-1"}).code, 0);
  EXPECT_NE(Vo({seq(), "--camera", "tum3", "--window", "0"}).code, 0);
  const CliResult d = Vo({seq(), "--camera", "tum3", "--distortion", "1,2"});
  EXPECT_EQ(d.code, 1);
  EXPECT_THAT(d.err, HasSubstr("--distortion '1,2'"));
}

TEST_F(VoCommandTest, DepthWithoutDepthFrames) {
  const CliResult r = Vo({seq(), "--camera", "tum3", "--depth"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("--depth"));
  EXPECT_THAT(r.err, HasSubstr("no depth frames"));
}

TEST_F(VoCommandTest, DetectorErrors) {
  const CliResult unknown = Vo({seq(), "--camera", "tum3", "--detector", "ssd"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("--detector 'ssd'"));
  const CliResult missing = Vo({seq(), "--camera", "tum3", "--detector",
                                "yolo:" + (dir_.path() / "y.cfg").string() + ",y.weights"});
  EXPECT_EQ(missing.code, 1);
  EXPECT_THAT(missing.err, HasSubstr("NOT_FOUND"));
  EXPECT_THAT(missing.err, HasSubstr("darknet cfg"));
  EXPECT_THAT(missing.err, HasSubstr("y.cfg"));
  const CliResult form = Vo({seq(), "--camera", "tum3", "--detector", "yolo:model.bin"});
  EXPECT_EQ(form.code, 1);
  EXPECT_THAT(form.err, HasSubstr("yolo:CFG,WEIGHTS"));
}

TEST(VoSessionTest, IntrinsicsPrecedence) {
  ImageSequence sequence;
  sequence.intrinsics = CameraIntrinsics{700, 710, 600, 180, {}, 0};
  VoArgs args;
  absl::StatusOr<CameraIntrinsics> c = ResolveIntrinsics(args, sequence);
  ASSERT_TRUE(c.ok());
  EXPECT_DOUBLE_EQ(c->fx, 700);  // calib.txt
  args.camera = "bonn";
  c = ResolveIntrinsics(args, sequence);
  EXPECT_DOUBLE_EQ(c->fx, 542.822841);  // the preset replaces calib.txt
  args.cx = 300;
  args.distortion = "0,0,0,0";
  args.depth_scale = 1000;
  c = ResolveIntrinsics(args, sequence);
  EXPECT_DOUBLE_EQ(c->cx, 300);  // a flag replaces the preset's value
  EXPECT_DOUBLE_EQ(c->cy, 237.756098);
  EXPECT_DOUBLE_EQ(c->distortion[0], 0);
  EXPECT_DOUBLE_EQ(c->depth_scale, 1000);

  ImageSequence bare;
  VoArgs flags;
  flags.fx = 500;
  flags.fy = 501;
  flags.cx = 320;
  flags.cy = 240;
  c = ResolveIntrinsics(flags, bare);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_DOUBLE_EQ(c->fy, 501);
  EXPECT_DOUBLE_EQ(c->depth_scale, 0);
}

TEST(VoSessionTest, RequestCarriesCameraDetectorAndFilter) {
  ScopedTempDir dir;
  WriteText(dir.path() / "m.cfg", "[net]\n");
  WriteText(dir.path() / "m.weights", "WEIGHTS");
  VoArgs args;
  args.sequence = "/data/bonn_crowd/";
  args.detector =
      "yolo:" + (dir.path() / "m.cfg").string() + "," + (dir.path() / "m.weights").string();
  args.movable = "person, car";
  args.filter = "boxes";
  args.depth = true;
  absl::StatusOr<v1::CreateSessionRequest> request =
      VoSessionRequest(args, *CameraPreset("bonn"), 640, 480);
  ASSERT_TRUE(request.ok()) << request.status();
  const v1::VisualSlamConfig& v = request->visual();
  EXPECT_FALSE(request->has_laser());
  EXPECT_DOUBLE_EQ(v.camera().fx(), 542.822841);
  EXPECT_EQ(v.camera().width(), 640u);
  EXPECT_EQ(v.camera().height(), 480u);
  ASSERT_EQ(v.camera().distortion_size(), 5);
  EXPECT_DOUBLE_EQ(v.camera().distortion(0), 0.039903);
  EXPECT_DOUBLE_EQ(v.depth_scale(), 5000);
  EXPECT_EQ(v.filter(), v1::VisualSlamConfig::FILTER_BOXES_ONLY);
  EXPECT_EQ(v.detector().kind(), v1::DetectorConfig::YOLO);
  EXPECT_EQ(v.detector().model_cfg(), "[net]\n");
  EXPECT_EQ(v.detector().model_weights(), "WEIGHTS");
  ASSERT_EQ(v.detector().movable_classes_size(), 2);
  EXPECT_EQ(v.detector().movable_classes(1), "car");

  args.detector = "hog";
  args.movable.clear();
  args.depth = false;
  request = VoSessionRequest(args, *CameraPreset("tum3"), 640, 480);
  ASSERT_TRUE(request.ok());
  EXPECT_EQ(request->visual().detector().kind(), v1::DetectorConfig::HOG);
  EXPECT_EQ(request->visual().camera().distortion_size(), 0);  // undistorted: none sent
  EXPECT_FALSE(request->visual().has_depth_scale());           // monocular run
  // Unset: the preset's, filled in by the server per input kind.
  EXPECT_EQ(request->visual().preset(), v1::VisualSlamConfig::PRESET_MEASURED_BEST);
  EXPECT_FALSE(request->visual().params().has_bundle_window());
  EXPECT_FALSE(request->visual().params().has_prior_direction_deg());
  EXPECT_FALSE(request->visual().params().has_static_hamming_fraction());
  EXPECT_FALSE(request->visual().params().has_proven_static_frames());

  args.filter.clear();
  request = VoSessionRequest(args, *CameraPreset("tum3"), 640, 480);
  ASSERT_TRUE(request.ok());
  EXPECT_FALSE(request->visual().has_filter());  // the preset's (measured best: proven)
  args.paper = true;                              // --paper
  request = VoSessionRequest(args, *CameraPreset("tum3"), 640, 480);
  ASSERT_TRUE(request.ok());
  EXPECT_EQ(request->visual().preset(), v1::VisualSlamConfig::PRESET_PAPER);
  EXPECT_FALSE(request->visual().has_filter());
  args.paper = false;

  args.filter = "proven";
  args.static_hamming = 1.0;
  args.proven_frames = 2;
  args.prior_direction_deg = 30;
  args.bundle_window = 8;
  args.relocalize = 40;
  request = VoSessionRequest(args, *CameraPreset("tum3"), 640, 480);
  ASSERT_TRUE(request.ok()) << request.status();
  EXPECT_EQ(request->visual().params().relocalization_keyframes(), 40u);
  EXPECT_EQ(request->visual().filter(), v1::VisualSlamConfig::FILTER_PROVEN);
  EXPECT_EQ(request->visual().params().prior_direction_deg(), 30.0);
  EXPECT_EQ(request->visual().params().bundle_window(), 8u);
  EXPECT_EQ(request->visual().params().static_hamming_fraction(), 1.0);
  EXPECT_EQ(request->visual().params().proven_static_frames(), 2u);
}

}  // namespace
}  // namespace waymark::cli
