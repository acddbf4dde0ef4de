#include "server/visual_slam/detectors/yolo_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <map>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "server/visual_slam/detectors/detector_input.h"

namespace waymark::visual_slam {
namespace {

constexpr int kMinInput = 32;
// Far above any real-time YOLO input; bounds the memory a client's cfg can make us allocate.
constexpr int kMaxInput = 1024;
constexpr int kOnnxDefaultInput = 640;  // YOLOv5's export size

enum class Format { kDarknet, kOnnx };

// What the cfg's [net] section says about the input.
struct NetSection {
  int width = 0, height = 0;
  bool letter_box = false;
};

// The next line of a darknet cfg with its comment (from '#' or ';') cut and surrounding
// whitespace trimmed, skipping lines left empty; false at the end.
bool NextCfgLine(std::istream& in, std::string* trimmed) {
  std::string line;
  while (std::getline(in, line)) {
    const size_t comment = line.find_first_of("#;");
    if (comment != std::string::npos) line.resize(comment);
    *trimmed = std::string(absl::StripAsciiWhitespace(line));
    if (!trimmed->empty()) return true;
  }
  return false;
}

// Reads width, height and letter_box from the cfg's first section, which darknet requires to be
// [net] (or [network]). OpenCV parses the rest; we need these before it runs.
absl::StatusOr<NetSection> ParseNetSection(const std::string& cfg) {
  std::istringstream in(cfg);
  std::string trimmed;
  bool in_net = false;
  NetSection net;
  while (NextCfgLine(in, &trimmed)) {
    if (trimmed.front() == '[') {
      if (in_net) break;  // the [net] section ended
      if (trimmed != "[net]" && trimmed != "[network]") {
        return absl::InvalidArgumentError(absl::StrCat(
            "yolo cfg: the first section must be [net], found ", trimmed.substr(0, 40)));
      }
      in_net = true;
      continue;
    }
    if (!in_net) {
      return absl::InvalidArgumentError("yolo cfg: text before the [net] section");
    }
    const size_t eq = trimmed.find('=');
    if (eq == std::string::npos) continue;
    const std::string key(absl::StripAsciiWhitespace(trimmed.substr(0, eq)));
    const std::string value(absl::StripAsciiWhitespace(trimmed.substr(eq + 1)));
    int number = 0;
    if (key == "width" || key == "height" || key == "letter_box") {
      if (!absl::SimpleAtoi(value, &number)) {
        return absl::InvalidArgumentError(
            absl::StrCat("yolo cfg: [net] ", key, " is not an integer: ", value.substr(0, 40)));
      }
      if (key == "width") net.width = number;
      if (key == "height") net.height = number;
      if (key == "letter_box") net.letter_box = number != 0;
    }
  }
  if (!in_net) return absl::InvalidArgumentError("yolo cfg: no [net] section (is it a cfg?)");
  if (net.width <= 0 || net.height <= 0) {
    return absl::InvalidArgumentError("yolo cfg: [net] needs positive width and height");
  }
  return net;
}

absl::Status CheckInputSide(int side, const char* what) {
  if (side < kMinInput || side > kMaxInput || side % 32 != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " is ", side, "; YOLO needs a multiple of 32 in [", kMinInput, ", ", kMaxInput, "]"));
  }
  return absl::OkStatus();
}

// Where the image sits in the network input: input = image * scale + pad.
struct Placement {
  float scale_x = 1, scale_y = 1;
  float pad_x = 0, pad_y = 0;
};

class YoloDetector : public ObjectDetector {
 public:
  YoloDetector(cv::dnn::Net net, Format format, cv::Size input, bool letterbox,
               std::vector<std::string> class_names, std::vector<bool> movable, float confidence,
               float nms)
      : net_(std::move(net)),
        format_(format),
        input_(input),
        letterbox_(letterbox),
        class_names_(std::move(class_names)),
        movable_(std::move(movable)),
        confidence_(confidence),
        nms_(nms),
        output_names_(net_.getUnconnectedOutLayersNames()) {}

  std::string name() const override { return "yolo"; }

  absl::StatusOr<std::vector<Box>> Detect(const cv::Mat& image) override {
    return DetectGuarded("yolo", image, 3,
                         [&](const cv::Mat& bgr) -> absl::StatusOr<std::vector<Box>> {
                           Placement placement;
                           const std::vector<cv::Mat> outputs = Forward(bgr, &placement);
                           return Decode(outputs, placement, image.size());
                         });
  }

  // Runs the network on a black frame: a model whose layers do not fit together fails here, at
  // session creation, not on the first frame; the output width is checked against the names.
  absl::Status SelfTest() {
    try {
      Placement placement;
      const std::vector<cv::Mat> outputs = Forward(cv::Mat::zeros(input_, CV_8UC3), &placement);
      for (const cv::Mat& out : outputs) {
        const int columns = out.dims >= 2 ? out.size[out.dims - 1] : 0;
        if (columns != 5 + static_cast<int>(class_names_.size())) {
          return absl::InvalidArgumentError(absl::StrCat(
              "yolo: the model's output rows have ", columns, " values; with ", class_names_.size(),
              " class_names they must have ", 5 + class_names_.size(),
              " (cx, cy, w, h, objectness, one score per class)"));
        }
      }
    } catch (const cv::Exception& e) {
      return absl::InvalidArgumentError(
          absl::StrCat("yolo: the model does not run in OpenCV dnn: ", ExceptionMessage(e)));
    } catch (const std::exception& e) {
      return absl::InvalidArgumentError(
          absl::StrCat("yolo: the model does not run in OpenCV dnn: ", ExceptionMessage(e)));
    }
    return absl::OkStatus();
  }

 private:
  // Fills the network input from the frame and runs it; throws cv::Exception on failure.
  std::vector<cv::Mat> Forward(const cv::Mat& bgr, Placement* placement) {
    cv::Mat blob;
    if (letterbox_) {
      // Keep the aspect ratio and pad the rest with grey, centred (darknet's letter_box and
      // YOLOv5's letterbox both centre the image).
      const float scale = std::min(static_cast<float>(input_.width) / bgr.cols,
                                   static_cast<float>(input_.height) / bgr.rows);
      const int w = std::max(1, static_cast<int>(std::round(bgr.cols * scale)));
      const int h = std::max(1, static_cast<int>(std::round(bgr.rows * scale)));
      cv::Mat canvas(input_, CV_8UC3, cv::Scalar::all(114));
      const int pad_x = (input_.width - w) / 2, pad_y = (input_.height - h) / 2;
      cv::resize(bgr, canvas(cv::Rect(pad_x, pad_y, w, h)), cv::Size(w, h), 0, 0, cv::INTER_LINEAR);
      placement->scale_x = static_cast<float>(w) / bgr.cols;
      placement->scale_y = static_cast<float>(h) / bgr.rows;
      placement->pad_x = static_cast<float>(pad_x);
      placement->pad_y = static_cast<float>(pad_y);
      blob = cv::dnn::blobFromImage(canvas, 1.0 / 255, cv::Size(), cv::Scalar(), /*swapRB=*/true,
                                    /*crop=*/false);
    } else {
      placement->scale_x = static_cast<float>(input_.width) / bgr.cols;
      placement->scale_y = static_cast<float>(input_.height) / bgr.rows;
      blob = cv::dnn::blobFromImage(bgr, 1.0 / 255, input_, cv::Scalar(), /*swapRB=*/true,
                                    /*crop=*/false);
    }
    net_.setInput(blob);
    std::vector<cv::Mat> outputs;
    net_.forward(outputs, output_names_);
    if (format_ == Format::kOnnx && outputs.size() > 1) outputs.resize(1);  // the detections
    return outputs;
  }

  absl::StatusOr<std::vector<Box>> Decode(const std::vector<cv::Mat>& outputs,
                                          const Placement& placement, cv::Size image) const {
    const int columns = 5 + static_cast<int>(class_names_.size());
    // Candidates per class index, for per-class NMS.
    std::map<int, std::pair<std::vector<cv::Rect2d>, std::vector<float>>> candidates;
    for (const cv::Mat& out : outputs) {
      if (!out.isContinuous() || out.type() != CV_32F || out.total() % columns != 0) {
        return absl::InternalError("yolo: unexpected output layout");
      }
      const int rows = static_cast<int>(out.total() / columns);
      for (int r = 0; r < rows; ++r) {
        const float* row = out.ptr<float>() + static_cast<size_t>(r) * columns;
        const float* scores = row + 5;
        const int best =
            static_cast<int>(std::max_element(scores, scores + class_names_.size()) - scores);
        // Darknet's rows carry objectness x probability already; ONNX exports keep them apart.
        const float score = format_ == Format::kDarknet ? scores[best] : row[4] * scores[best];
        if (!(score >= confidence_) || !movable_[best]) continue;
        float cx = row[0], cy = row[1], w = row[2], h = row[3];
        if (format_ == Format::kDarknet) {  // fractions of the input -> input pixels
          cx *= input_.width;
          cy *= input_.height;
          w *= input_.width;
          h *= input_.height;
        }
        // Input pixels -> image pixels.
        const double x0 = (cx - w / 2 - placement.pad_x) / placement.scale_x;
        const double y0 = (cy - h / 2 - placement.pad_y) / placement.scale_y;
        const double bw = w / placement.scale_x, bh = h / placement.scale_y;
        if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(bw) || !std::isfinite(bh) ||
            bw <= 0 || bh <= 0) {
          continue;
        }
        auto& [rects, confidences] = candidates[best];
        rects.emplace_back(x0, y0, bw, bh);
        confidences.push_back(score);
      }
    }
    std::vector<Box> boxes;
    const cv::Rect2d frame(0, 0, image.width, image.height);
    for (const auto& [class_index, candidate] : candidates) {
      const auto& [rects, confidences] = candidate;
      std::vector<int> kept;
      cv::dnn::NMSBoxes(rects, confidences, confidence_, nms_, kept);
      for (int i : kept) {
        if (std::optional<Box> box =
                ClippedBox(rects[i], frame, class_names_[class_index], confidences[i])) {
          boxes.push_back(*std::move(box));
        }
      }
    }
    std::sort(boxes.begin(), boxes.end(),
              [](const Box& a, const Box& b) { return a.confidence > b.confidence; });
    return boxes;
  }

  cv::dnn::Net net_;
  Format format_;
  cv::Size input_;
  bool letterbox_;
  std::vector<std::string> class_names_;
  std::vector<bool> movable_;  // per class index
  float confidence_;
  float nms_;
  std::vector<std::string> output_names_;
};

// OpenCV reads darknet weights without checking that the bytes last: a truncated file loads
// with garbage filters, and a longer one (weights of another cfg) loads silently. Darknet writes
// a header, then per convolutional layer its biases, batch-norm scales/means/variances and filter
// weights, which OpenCV keeps as the Convolution and BatchNorm layers' blobs: the file must be
// exactly header + 4 bytes per blob element.
absl::Status CheckWeightsSize(cv::dnn::Net& net, const std::string& weights) {
  size_t floats = 0;
  for (const std::string& layer_name : net.getLayerNames()) {
    cv::Ptr<cv::dnn::Layer> layer = net.getLayer(layer_name);
    if (layer->type != "Convolution" && layer->type != "BatchNorm") continue;
    for (const cv::Mat& blob : layer->blobs) floats += blob.total();
  }
  size_t header = 3 * sizeof(int32_t) + sizeof(int32_t);
  if (weights.size() >= 2 * sizeof(int32_t)) {
    int32_t major = 0, minor = 0;
    std::memcpy(&major, weights.data(), sizeof major);
    std::memcpy(&minor, weights.data() + sizeof major, sizeof minor);
    // Darknet's rule: from version 0.2 the "images seen" counter is 64-bit.
    if (major * 10 + minor >= 2 && major < 1000 && minor < 1000) {
      header = 3 * sizeof(int32_t) + sizeof(int64_t);
    }
  }
  const size_t expected = header + floats * sizeof(float);
  if (weights.size() != expected) {
    return absl::InvalidArgumentError(absl::StrCat("yolo: weights has ", weights.size(),
                                                   " bytes; the cfg's layers need ", expected,
                                                   " (truncated, or the weights of another cfg)"));
  }
  return absl::OkStatus();
}

// A cfg is client data: a [convolutional] section asking for more filters than the weights
// could hold would make OpenCV allocate them before anything is checked. Each filter needs at
// least size x size weights and a bias, so the sum bounds the weights from below.
absl::Status CheckFiltersFitWeights(const std::string& cfg, size_t weights_bytes) {
  std::istringstream in(cfg);
  std::string trimmed;
  bool in_conv = false;
  double filters = 1, size = 1, needed = 0;
  auto close_section = [&] {
    if (in_conv) needed += filters * (size * size + 1);
    in_conv = false;
    filters = 1;
    size = 1;
  };
  while (NextCfgLine(in, &trimmed)) {
    if (trimmed.front() == '[') {
      close_section();
      in_conv = trimmed == "[convolutional]" || trimmed == "[conv]";
      continue;
    }
    const size_t eq = trimmed.find('=');
    if (!in_conv || eq == std::string::npos) continue;
    const std::string key(absl::StripAsciiWhitespace(trimmed.substr(0, eq)));
    double value = 0;
    if ((key == "filters" || key == "size") &&
        absl::SimpleAtod(absl::StripAsciiWhitespace(trimmed.substr(eq + 1)), &value) && value > 0) {
      (key == "filters" ? filters : size) = value;
    }
  }
  close_section();
  if (needed * sizeof(float) > static_cast<double>(weights_bytes)) {
    return absl::InvalidArgumentError(
        absl::StrCat("yolo: the cfg's convolutional layers need more than ", weights_bytes,
                     " bytes of weights (the weights do not belong to this cfg)"));
  }
  return absl::OkStatus();
}

// Builds the net from the bytes; OpenCV reports bad bytes by throwing, which must not leave here.
absl::StatusOr<cv::dnn::Net> LoadNet(const YoloOptions& options, Format format) {
  cv::dnn::Net net;
  try {
    if (format == Format::kDarknet) {
      if (absl::Status s = CheckFiltersFitWeights(options.cfg, options.weights.size()); !s.ok()) {
        return s;
      }
      net = cv::dnn::readNetFromDarknet(options.cfg.data(), options.cfg.size(),
                                        options.weights.data(), options.weights.size());
    } else {
      // OpenCV 4.6's readNet(framework, buffer) knows no "onnx"; this is its buffer entry point.
      net = cv::dnn::readNetFromONNX(options.onnx.data(), options.onnx.size());
    }
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("yolo: OpenCV cannot load the ",
                     format == Format::kDarknet ? "darknet cfg/weights" : "onnx model", ": ",
                     ExceptionMessage(e)));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("yolo: cannot load the model: ", ExceptionMessage(e)));
  }
  if (net.empty()) return absl::InvalidArgumentError("yolo: the model has no layers");
  if (format == Format::kDarknet) {
    if (absl::Status s = CheckWeightsSize(net, options.weights); !s.ok()) return s;
  }
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  return net;
}

}  // namespace

absl::StatusOr<std::unique_ptr<ObjectDetector>> MakeYoloDetector(const YoloOptions& options) {
  const bool darknet = !options.cfg.empty() || !options.weights.empty();
  const bool onnx = !options.onnx.empty();
  if (!darknet && !onnx) {
    return absl::InvalidArgumentError("yolo: no model: set cfg and weights, or onnx");
  }
  if (darknet && onnx) {
    return absl::InvalidArgumentError("yolo: set either cfg and weights or onnx, not both");
  }
  if (darknet && (options.cfg.empty() || options.weights.empty())) {
    return absl::InvalidArgumentError(
        absl::StrCat("yolo: a darknet model needs both cfg and weights; ",
                     options.cfg.empty() ? "cfg" : "weights", " is empty"));
  }
  if (options.class_names.empty()) {
    return absl::InvalidArgumentError("yolo: class_names is empty");
  }
  if (!(options.confidence > 0 && options.confidence <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("yolo: confidence is ", options.confidence, "; it must be in (0, 1]"));
  }
  if (!(options.nms > 0 && options.nms <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("yolo: nms is ", options.nms, "; it must be in (0, 1]"));
  }
  std::vector<bool> movable(options.class_names.size(), false);
  for (const std::string& name : options.movable_classes) {
    auto it = std::find(options.class_names.begin(), options.class_names.end(), name);
    if (it == options.class_names.end()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "yolo: movable class \"", name, "\" is not one of the model's ",
          options.class_names.size(), " class_names (e.g. ",
          absl::StrJoin(
              options.class_names.begin(),
              options.class_names.begin() + std::min<size_t>(6, options.class_names.size()), ", "),
          ")"));
    }
    movable[it - options.class_names.begin()] = true;
  }

  const Format format = darknet ? Format::kDarknet : Format::kOnnx;
  cv::Size input;
  bool letterbox = true;
  if (format == Format::kDarknet) {
    auto net_section = ParseNetSection(options.cfg);
    if (!net_section.ok()) return net_section.status();
    letterbox = net_section->letter_box;
    input = cv::Size(net_section->width, net_section->height);
  } else {
    input = cv::Size(kOnnxDefaultInput, kOnnxDefaultInput);
  }
  if (options.input_size != 0) {
    if (auto s = CheckInputSide(options.input_size, "yolo: input_size"); !s.ok()) return s;
    input = cv::Size(options.input_size, options.input_size);
  } else {
    if (auto s = CheckInputSide(input.width, "yolo: the cfg's width"); !s.ok()) return s;
    if (auto s = CheckInputSide(input.height, "yolo: the cfg's height"); !s.ok()) return s;
  }

  auto net = LoadNet(options, format);
  if (!net.ok()) return net.status();
  auto detector =
      std::make_unique<YoloDetector>(*std::move(net), format, input, letterbox, options.class_names,
                                     std::move(movable), options.confidence, options.nms);
  if (absl::Status s = detector->SelfTest(); !s.ok()) return s;
  return detector;
}

}  // namespace waymark::visual_slam
