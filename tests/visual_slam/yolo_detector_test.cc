// YoloDetector on real frames with YOLO-Fastest 1.1 XL (COCO) from ../shared/models, against
// boxes judged by eye on the frames (coordinates below, in the frame's pixels), plus the ONNX
// path on a hand-encoded network whose output is known exactly, and bad model bytes.

#include "server/visual_slam/detectors/yolo_detector.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "server/visual_slam/detectors/coco_classes.h"
#include "tests/visual_slam/detector_testing.h"

namespace waymark::visual_slam {
namespace {

using ::testing::HasSubstr;
using ::waymark::visual_slam::testing::DetectOrDie;
using ::waymark::visual_slam::testing::DetectorOrDie;

const std::string kModelDir = WAYMARK_SHARED_DIR "/models/yolo-fastest-1.1-coco/";
const std::string kVslam = WAYMARK_SHARED_DIR "/data/vslam/";
// TUM fr3/walking_xyz: a seated and a standing man; the office with nobody in it.
const std::string kTumTwoPeople = kVslam + "tum_fr3_walking_xyz_3frames/rgb/1341846313.592026.png";
const std::string kTumNobody = kVslam + "tum_fr3_walking_xyz_3frames/rgb/1341846325.417931.png";
// Bonn crowd: frame 270 (two men walking past, one behind the other), 380 (a man from behind,
// another cut by the right edge), 409 (three men).
const std::string kBonn = kVslam + "bonn_rgbd_crowd_frames270-409/rgb/";
const std::string kBonn270 = kBonn + "1548339828.92438.png";
const std::string kBonn380 = kBonn + "1548339832.61140.png";
const std::string kBonn409 = kBonn + "1548339833.58336.png";
// KITTI 06 frame 25 (gray, 1226x370): a parked hatchback close on the right.
const std::string kKitti25 = kVslam + "kitti_odom06_frames000-050/image_0/000025.png";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

YoloOptions ModelOptions() {
  YoloOptions options;
  options.cfg = ReadFile(kModelDir + "yolo-fastest-1.1-xl.cfg");
  options.weights = ReadFile(kModelDir + "yolo-fastest-1.1-xl.weights");
  return options;
}

std::unique_ptr<ObjectDetector> MakeOrDie(const YoloOptions& options) {
  return DetectorOrDie(MakeYoloDetector(options));
}

double IoU(const Box& box, const cv::Rect2d& truth) {
  const cv::Rect2d r(box.x, box.y, box.w, box.h);
  const double inter = (r & truth).area();
  return inter / (r.area() + truth.area() - inter);
}

// The best IoU of a `label` box with `truth` (0 if none).
double BestIoU(const std::vector<Box>& boxes, const std::string& label, const cv::Rect2d& truth) {
  double best = 0;
  for (const Box& b : boxes) {
    if (b.label == label) best = std::max(best, IoU(b, truth));
  }
  return best;
}

int Count(const std::vector<Box>& boxes, const std::string& label) {
  return static_cast<int>(
      std::count_if(boxes.begin(), boxes.end(), [&](const Box& b) { return b.label == label; }));
}

void ExpectInside(const std::vector<Box>& boxes, const cv::Mat& image) {
  for (const Box& b : boxes) {
    EXPECT_GE(b.x, 0);
    EXPECT_GE(b.y, 0);
    EXPECT_GT(b.w, 0);
    EXPECT_GT(b.h, 0);
    EXPECT_LE(b.x + b.w, image.cols + 1e-3);
    EXPECT_LE(b.y + b.h, image.rows + 1e-3);
  }
}

TEST(CocoClassNames, EqualsDarknetCocoNames) {
  SKIP_WITHOUT(kModelDir + "coco.names");
  std::istringstream in(ReadFile(kModelDir + "coco.names"));
  std::vector<std::string> names;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) names.push_back(line);
  }
  ASSERT_EQ(names.size(), 80u);
  EXPECT_EQ(CocoClassNames(), names);
}

TEST(YoloDetector, FindsTheSeatedAndTheStandingManOnTum) {
  SKIP_WITHOUT(kTumTwoPeople);
  auto detector = MakeOrDie(ModelOptions());
  ASSERT_NE(detector, nullptr);
  EXPECT_EQ(detector->name(), "yolo");
  const cv::Mat image = cv::imread(kTumTwoPeople, cv::IMREAD_COLOR);
  const auto boxes = DetectOrDie(*detector, image);
  // By eye: the seated man, head to feet, and the standing man cut by the right and top edges.
  EXPECT_GE(BestIoU(boxes, "person", cv::Rect2d(50, 120, 190, 350)), 0.6);
  EXPECT_GE(BestIoU(boxes, "person", cv::Rect2d(480, 0, 160, 480)), 0.6);
  EXPECT_EQ(Count(boxes, "person"), 2);
  // The chairs, monitors and keyboards the network also sees are not movable classes.
  const std::set<std::string> movable = {"person", "car", "bus", "truck", "bicycle", "motorbike"};
  for (const Box& b : boxes) EXPECT_TRUE(movable.count(b.label)) << b.label;
  ExpectInside(boxes, image);
}

TEST(YoloDetector, NoBoxOnTheEmptyOffice) {
  SKIP_WITHOUT(kTumNobody);
  auto detector = MakeOrDie(ModelOptions());
  ASSERT_NE(detector, nullptr);
  EXPECT_THAT(DetectOrDie(*detector, cv::imread(kTumNobody, cv::IMREAD_COLOR)),
              ::testing::IsEmpty());
}

TEST(YoloDetector, FindsTheWalkersOnBonnCrowdFrames) {
  SKIP_WITHOUT(kBonn409);
  auto detector = MakeOrDie(ModelOptions());
  ASSERT_NE(detector, nullptr);
  // Frame 270: the two overlapping walkers (x 215-420) make one box.
  const auto b270 = DetectOrDie(*detector, cv::imread(kBonn270, cv::IMREAD_COLOR));
  EXPECT_GE(BestIoU(b270, "person", cv::Rect2d(215, 0, 205, 480)), 0.6);
  // Frame 380: the man seen from behind.
  const auto b380 = DetectOrDie(*detector, cv::imread(kBonn380, cv::IMREAD_COLOR));
  EXPECT_GE(BestIoU(b380, "person", cv::Rect2d(175, 45, 110, 365)), 0.6);
  // Frame 409: the three men (left, blurred and close; middle; right, cut by the edge).
  const cv::Mat image = cv::imread(kBonn409, cv::IMREAD_COLOR);
  const auto b409 = DetectOrDie(*detector, image);
  EXPECT_GE(BestIoU(b409, "person", cv::Rect2d(10, 0, 210, 480)), 0.6);
  EXPECT_GE(BestIoU(b409, "person", cv::Rect2d(275, 55, 100, 350)), 0.6);
  EXPECT_GE(BestIoU(b409, "person", cv::Rect2d(515, 95, 125, 385)), 0.5);
  EXPECT_EQ(Count(b409, "person"), 3);
  ExpectInside(b409, image);
}

TEST(YoloDetector, FindsTheParkedCarOnGrayKitti) {
  SKIP_WITHOUT(kKitti25);
  auto detector = MakeOrDie(ModelOptions());
  ASSERT_NE(detector, nullptr);
  const cv::Mat gray = cv::imread(kKitti25, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(gray.channels(), 1);
  const auto boxes = DetectOrDie(*detector, gray);
  EXPECT_GE(BestIoU(boxes, "car", cv::Rect2d(806, 180, 321, 170)), 0.6);
  EXPECT_EQ(Count(boxes, "person"), 0);
  ExpectInside(boxes, gray);
}

TEST(YoloDetector, MovableClassesFilterTheLabels) {
  SKIP_WITHOUT(kKitti25);
  YoloOptions options = ModelOptions();
  options.movable_classes = {"car"};
  auto detector = MakeOrDie(options);
  ASSERT_NE(detector, nullptr);
  // The people of TUM are no longer reported...
  EXPECT_THAT(DetectOrDie(*detector, cv::imread(kTumTwoPeople, cv::IMREAD_COLOR)),
              ::testing::IsEmpty());
  // ...the car of KITTI still is, and nothing but cars.
  const auto boxes = DetectOrDie(*detector, cv::imread(kKitti25, cv::IMREAD_UNCHANGED));
  EXPECT_GE(BestIoU(boxes, "car", cv::Rect2d(806, 180, 321, 170)), 0.6);
  EXPECT_EQ(Count(boxes, "car"), static_cast<int>(boxes.size()));
}

TEST(YoloDetector, OtherInputSizesStillFindThePeople) {
  SKIP_WITHOUT(kTumTwoPeople);
  const cv::Mat image = cv::imread(kTumTwoPeople, cv::IMREAD_COLOR);
  for (int size : {256, 416}) {
    YoloOptions options = ModelOptions();
    options.input_size = size;
    auto detector = MakeOrDie(options);
    ASSERT_NE(detector, nullptr);
    const auto boxes = DetectOrDie(*detector, image);
    EXPECT_GE(BestIoU(boxes, "person", cv::Rect2d(50, 120, 190, 350)), 0.5) << size;
    EXPECT_GE(BestIoU(boxes, "person", cv::Rect2d(480, 0, 160, 480)), 0.5) << size;
  }
}

TEST(YoloDetector, TinyBlackAndBadImages) {
  SKIP_WITHOUT(kModelDir + "yolo-fastest-1.1-xl.cfg");
  auto detector = MakeOrDie(ModelOptions());
  ASSERT_NE(detector, nullptr);
  EXPECT_THAT(DetectOrDie(*detector, cv::Mat(1, 1, CV_8UC3, cv::Scalar::all(128))),
              ::testing::IsEmpty());
  EXPECT_THAT(DetectOrDie(*detector, cv::Mat::zeros(480, 640, CV_8UC3)), ::testing::IsEmpty());
  EXPECT_THAT(DetectOrDie(*detector, cv::Mat::zeros(480, 640, CV_8UC1)), ::testing::IsEmpty());
  EXPECT_EQ(detector->Detect(cv::Mat()).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(detector->Detect(cv::Mat::zeros(8, 8, CV_16UC1)).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(detector->Detect(cv::Mat::zeros(8, 8, CV_8UC4)).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// --- bad options and model bytes: INVALID_ARGUMENT naming the problem, never a crash ----------

void ExpectInvalid(const YoloOptions& options, const std::string& message_part) {
  auto detector = MakeYoloDetector(options);
  ASSERT_FALSE(detector.ok()) << "accepted; expected an error with: " << message_part;
  EXPECT_EQ(detector.status().code(), absl::StatusCode::kInvalidArgument) << detector.status();
  EXPECT_THAT(std::string(detector.status().message()), HasSubstr(message_part));
}

std::string Junk(size_t size, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string bytes(size, '\0');
  for (char& c : bytes) c = static_cast<char>(rng());
  return bytes;
}

TEST(MakeYoloDetector, RefusesMissingOrMixedModels) {
  ExpectInvalid(YoloOptions{}, "no model");
  YoloOptions only_cfg;
  only_cfg.cfg = "[net]\nwidth=320\nheight=320\n";
  ExpectInvalid(only_cfg, "weights is empty");
  YoloOptions both = only_cfg;
  both.weights = Junk(100, 1);
  both.onnx = Junk(100, 2);
  ExpectInvalid(both, "not both");
}

TEST(MakeYoloDetector, RefusesGarbageBytes) {
  YoloOptions junk;
  junk.cfg = Junk(5000, 3);
  junk.weights = Junk(5000, 4);
  ExpectInvalid(junk, "cfg");
  YoloOptions onnx;
  onnx.onnx = Junk(5000, 5);
  ExpectInvalid(onnx, "cannot load the onnx model");
}

TEST(MakeYoloDetector, RefusesWeightsThatDoNotFitTheCfg) {
  SKIP_WITHOUT(kModelDir + "yolo-fastest-1.1-xl.weights");
  const YoloOptions good = ModelOptions();
  YoloOptions truncated = good;
  truncated.weights.resize(good.weights.size() / 2);
  ExpectInvalid(truncated, "weights has 1846982 bytes; the cfg's layers need 3693964");
  YoloOptions longer = good;
  longer.weights += std::string(16, '\0');
  ExpectInvalid(longer, "the cfg's layers need 3693964");
  YoloOptions random = good;
  random.weights = Junk(good.weights.size(), 6);  // right size, garbage header and filters
  auto detector = MakeYoloDetector(random);
  // OpenCV may load such bytes (every float is some float); it must not crash either way.
  if (!detector.ok()) {
    EXPECT_EQ(detector.status().code(), absl::StatusCode::kInvalidArgument);
  }
  YoloOptions tiny = good;
  tiny.weights = Junk(10, 7);
  ExpectInvalid(tiny, "need more than 10 bytes of weights");
}

TEST(MakeYoloDetector, RefusesBrokenCfgs) {
  SKIP_WITHOUT(kModelDir + "yolo-fastest-1.1-xl.weights");
  const YoloOptions good = ModelOptions();
  YoloOptions cut = good;
  cut.cfg.resize(good.cfg.size() / 2);
  ExpectInvalid(cut, "yolo");
  YoloOptions unknown_layer = good;
  unknown_layer.cfg = "[net]\nwidth=320\nheight=320\nchannels=3\n[bogus]\nx=1\n";
  ExpectInvalid(unknown_layer, "Unknown layer type: bogus");
  YoloOptions no_net = good;
  no_net.cfg = "[convolutional]\nfilters=16\nsize=3\n";
  ExpectInvalid(no_net, "must be [net]");
  YoloOptions huge = good;
  huge.cfg =
      "[net]\nwidth=320\nheight=320\nchannels=3\n[convolutional]\nfilters=1000000000\n"
      "size=3\nstride=1\npad=1\nactivation=leaky\n";
  ExpectInvalid(huge, "need more than");
  YoloOptions odd_size = good;
  odd_size.cfg = "[net]\nwidth=300\nheight=320\n" + good.cfg.substr(good.cfg.find("channels"));
  ExpectInvalid(odd_size, "the cfg's width is 300");
}

TEST(MakeYoloDetector, RefusesBadOptions) {
  SKIP_WITHOUT(kModelDir + "yolo-fastest-1.1-xl.weights");
  YoloOptions unknown = ModelOptions();
  unknown.movable_classes = {"person", "pedestrian"};
  ExpectInvalid(unknown, "movable class \"pedestrian\" is not one of the model's 80 class_names");
  YoloOptions names = ModelOptions();
  names.class_names = {"person", "car"};
  names.movable_classes = {"person"};
  ExpectInvalid(names, "with 2 class_names they must have 7");
  YoloOptions size = ModelOptions();
  size.input_size = 300;
  ExpectInvalid(size, "input_size is 300");
  size.input_size = 4096;
  ExpectInvalid(size, "input_size is 4096");
  YoloOptions confidence = ModelOptions();
  confidence.confidence = std::numeric_limits<float>::quiet_NaN();
  ExpectInvalid(confidence, "confidence");
  confidence.confidence = 0;
  ExpectInvalid(confidence, "confidence");
  YoloOptions nms = ModelOptions();
  nms.nms = 1.5f;
  ExpectInvalid(nms, "nms");
}

// --- ONNX: a hand-encoded network with a known output --------------------------------------

// Protobuf wire format, enough for an ONNX ModelProto.
class Proto {
 public:
  Proto& Int(int field, uint64_t value) {
    Tag(field, 0);
    Varint(value);
    return *this;
  }
  Proto& Bytes(int field, const std::string& bytes) {
    Tag(field, 2);
    Varint(bytes.size());
    bytes_ += bytes;
    return *this;
  }
  Proto& Message(int field, const Proto& message) { return Bytes(field, message.bytes_); }
  const std::string& bytes() const { return bytes_; }

 private:
  void Tag(int field, int wire_type) { Varint(static_cast<uint64_t>(field) << 3 | wire_type); }
  void Varint(uint64_t value) {
    for (; value >= 0x80; value >>= 7) bytes_ += static_cast<char>(value | 0x80);
    bytes_ += static_cast<char>(value);
  }
  std::string bytes_;
};

template <typename T>
std::string RawBytes(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

// onnx.proto field numbers: TensorProto dims=1 data_type=2 name=8 raw_data=9; ValueInfoProto
// name=1 type=2; TypeProto tensor_type=1 (elem_type=1 shape=2; dim=1; dim_value=1); NodeProto
// input=1 output=2 name=3 op_type=4 attribute=5 (name=1 i=3 type=20); GraphProto node=1 name=2
// initializer=5 input=11 output=12; ModelProto ir_version=1 producer_name=2 graph=7
// opset_import=8 (domain=1 version=2).
Proto Tensor(const std::string& name, const std::vector<int64_t>& dims, int type,
             const std::string& raw) {
  Proto tensor;
  for (int64_t d : dims) tensor.Int(1, d);
  return tensor.Int(2, type).Bytes(8, name).Bytes(9, raw);
}

Proto ValueInfo(const std::string& name, const std::vector<int64_t>& dims) {
  Proto shape;
  for (int64_t d : dims) shape.Message(1, Proto().Int(1, d));
  constexpr int kFloat = 1;
  return Proto().Bytes(1, name).Message(
      2, Proto().Message(1, Proto().Int(1, kFloat).Message(2, shape)));
}

Proto Node(const std::vector<std::string>& inputs, const std::string& output, const std::string& op,
           const std::string& int_attribute = "", int value = 0) {
  Proto node;
  for (const std::string& input : inputs) node.Bytes(1, input);
  node.Bytes(2, output).Bytes(3, output).Bytes(4, op);
  constexpr int kInt = 2;
  if (!int_attribute.empty()) {
    node.Message(5, Proto().Bytes(1, int_attribute).Int(3, value).Int(20, kInt));
  }
  return node;
}

// x[1,3,side,side] -> GlobalAveragePool -> Flatten -> Gemm with zero weights and the rows as its
// bias -> Reshape [1, R, C]: whatever the image, the output is `rows`.
std::string ConstantRowsOnnx(const std::vector<std::vector<float>>& rows, int side) {
  const int64_t r = rows.size(), c = rows[0].size();
  std::vector<float> bias;
  for (const auto& row : rows) bias.insert(bias.end(), row.begin(), row.end());
  constexpr int kFloat = 1, kInt64 = 7;
  Proto graph;
  graph.Message(1, Node({"x"}, "pooled", "GlobalAveragePool"))
      .Message(1, Node({"pooled"}, "flat", "Flatten", "axis", 1))
      .Message(1, Node({"flat", "w", "b"}, "gemm", "Gemm", "transB", 1))
      .Message(1, Node({"gemm", "shape"}, "y", "Reshape"))
      .Bytes(2, "constant_rows")
      .Message(5, Tensor("w", {r * c, 3}, kFloat, RawBytes(std::vector<float>(r * c * 3, 0.f))))
      .Message(5, Tensor("b", {r * c}, kFloat, RawBytes(bias)))
      .Message(5, Tensor("shape", {3}, kInt64, RawBytes(std::vector<int64_t>{1, r, c})))
      .Message(11, ValueInfo("x", {1, 3, side, side}))
      .Message(12, ValueInfo("y", {1, r, c}));
  return Proto()
      .Int(1, 7)
      .Bytes(2, "waymark-test")
      .Message(7, graph)
      .Message(8, Proto().Bytes(1, "").Int(2, 11))
      .bytes();
}

// A YOLOv5-style row: box in input pixels, objectness, one class probability.
std::vector<float> Row(float cx, float cy, float w, float h, float objectness, int class_index,
                       float probability, int classes = 80) {
  std::vector<float> row(5 + classes, 0.f);
  row[0] = cx;
  row[1] = cy;
  row[2] = w;
  row[3] = h;
  row[4] = objectness;
  row[5 + class_index] = probability;
  return row;
}

TEST(YoloDetectorOnnx, DecodesLetterboxedRowsWithNmsAndClassFilter) {
  constexpr int kChair = 56;
  YoloOptions options;
  options.onnx = ConstantRowsOnnx(
      {
          Row(320, 320, 200, 400, 0.9f, 0, 0.9f),      // person, score 0.81
          Row(330, 330, 200, 400, 0.9f, 0, 0.5f),      // the same person, weaker: NMS drops it
          Row(100, 500, 80, 60, 0.9f, kChair, 0.95f),  // a chair: not movable
          Row(600, 100, 50, 50, 0.5f, 2, 0.4f),        // car at 0.2 < confidence 0.25
          Row(630, 560, 40, 40, 0.9f, 2, 0.8f),        // car over the bottom-right corner, 0.72
      },
      640);
  auto detector = MakeOrDie(options);
  ASSERT_NE(detector, nullptr);
  // 640x480 letterboxed into 640x640: scale 1, 80 rows of padding above.
  const auto boxes = DetectOrDie(*detector, cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(90)));
  ASSERT_EQ(boxes.size(), 2u);
  EXPECT_EQ(boxes[0].label, "person");
  EXPECT_NEAR(boxes[0].confidence, 0.81, 1e-5);
  EXPECT_NEAR(boxes[0].x, 220, 1e-3);
  EXPECT_NEAR(boxes[0].y, 40, 1e-3);
  EXPECT_NEAR(boxes[0].w, 200, 1e-3);
  EXPECT_NEAR(boxes[0].h, 400, 1e-3);
  // Car: input box (610, 540)-(650, 580) -> image (610, 460)-(650, 500), clipped to 640x480.
  EXPECT_EQ(boxes[1].label, "car");
  EXPECT_NEAR(boxes[1].x, 610, 1e-3);
  EXPECT_NEAR(boxes[1].y, 460, 1e-3);
  EXPECT_NEAR(boxes[1].w, 30, 1e-3);
  EXPECT_NEAR(boxes[1].h, 20, 1e-3);

  // A 320x240 frame at input 320: scale 1 again, 40 rows of padding; the rows are constants,
  // so the same input-pixel boxes now fall further out of the smaller frame.
  options.input_size = 320;
  detector = MakeOrDie(options);
  ASSERT_NE(detector, nullptr);
  const auto small = DetectOrDie(*detector, cv::Mat(240, 320, CV_8UC1, cv::Scalar::all(90)));
  ASSERT_FALSE(small.empty());
  EXPECT_EQ(small[0].label, "person");
  // Input box (220, 120)-(420, 520) -> image (220, 80)-(420, 480), clipped to 320x240.
  EXPECT_NEAR(small[0].x, 220, 1e-3);
  EXPECT_NEAR(small[0].y, 80, 1e-3);
  EXPECT_NEAR(small[0].w, 100, 1e-3);
  EXPECT_NEAR(small[0].h, 160, 1e-3);
}

TEST(YoloDetectorOnnx, RefusesOutputsThatDoNotMatchTheClassNames) {
  YoloOptions options;
  options.onnx = ConstantRowsOnnx({Row(320, 320, 200, 400, 0.9f, 0, 0.9f, /*classes=*/3)}, 640);
  ExpectInvalid(options, "with 80 class_names they must have 85");
  options.class_names = {"person", "bicycle", "car"};
  options.movable_classes = {"person", "car"};
  auto detector = MakeOrDie(options);
  ASSERT_NE(detector, nullptr);
  const auto boxes = DetectOrDie(*detector, cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(0)));
  ASSERT_EQ(boxes.size(), 1u);
  EXPECT_EQ(boxes[0].label, "person");
}

}  // namespace
}  // namespace waymark::visual_slam
