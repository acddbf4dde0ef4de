#include "client/sessions/vo_session.h"

#include <filesystem>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

// A model file's bytes; the server never opens client paths, so they travel in the request.
absl::StatusOr<std::string> ReadModel(const std::string& path, const char* role) {
  if (path.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--detector: the ", role, " file name is empty"));
  }
  absl::StatusOr<std::string> bytes = ReadFileBytes(path);
  if (!bytes.ok()) {
    return absl::Status(bytes.status().code(),
                        absl::StrCat("--detector: ", role, " file: ", bytes.status().message()));
  }
  if (bytes->empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--detector: ", role, " file '", path, "' is empty"));
  }
  return bytes;
}

}  // namespace

absl::StatusOr<CameraIntrinsics> ResolveIntrinsics(const VoArgs& args,
                                                   const ImageSequence& sequence) {
  std::optional<CameraIntrinsics> base = sequence.intrinsics;
  if (!args.camera.empty()) {
    absl::StatusOr<CameraIntrinsics> preset = CameraPreset(args.camera);
    if (!preset.ok()) return preset.status();
    base = *preset;
  }
  if (!base) {
    std::vector<std::string> missing;
    if (!args.fx) missing.push_back("--fx");
    if (!args.fy) missing.push_back("--fy");
    if (!args.cx) missing.push_back("--cx");
    if (!args.cy) missing.push_back("--cy");
    if (!missing.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "'", sequence.dir.string(), "' has no camera calibration (",
          SequenceLayoutName(sequence.layout), " layout): give --camera PRESET (",
          CameraPresetNames(), ") or --fx --fy --cx --cy; missing ", absl::StrJoin(missing, " ")));
    }
    base = CameraIntrinsics{};
  }
  CameraIntrinsics camera = *base;
  if (args.fx) camera.fx = *args.fx;
  if (args.fy) camera.fy = *args.fy;
  if (args.cx) camera.cx = *args.cx;
  if (args.cy) camera.cy = *args.cy;
  if (!args.distortion.empty()) {
    absl::StatusOr<std::array<double, 5>> distortion = ParseDistortion(args.distortion);
    if (!distortion.ok()) return distortion.status();
    camera.distortion = *distortion;
  }
  if (args.depth_scale) camera.depth_scale = *args.depth_scale;
  if (!(camera.fx > 0 && camera.fy > 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("focal lengths must be positive (fx ", camera.fx, ", fy ", camera.fy, ")"));
  }
  return camera;
}

absl::StatusOr<v1::DetectorConfig> DetectorFromSpec(const std::string& spec,
                                                    const std::string& movable) {
  v1::DetectorConfig config;
  if (spec == "none") {
    config.set_kind(v1::DetectorConfig::DETECTOR_NONE);
  } else if (spec == "hog") {
    config.set_kind(v1::DetectorConfig::HOG);
  } else if (absl::StartsWith(spec, "yolo:")) {
    config.set_kind(v1::DetectorConfig::YOLO);
    const std::string files = spec.substr(5);
    const std::vector<std::string> parts = absl::StrSplit(files, ',');
    if (parts.size() == 1 &&
        absl::AsciiStrToLower(std::filesystem::path(parts[0]).extension().string()) == ".onnx") {
      absl::StatusOr<std::string> onnx = ReadModel(parts[0], "ONNX model");
      if (!onnx.ok()) return onnx.status();
      config.set_model_onnx(*std::move(onnx));
    } else if (parts.size() == 2) {
      absl::StatusOr<std::string> cfg = ReadModel(parts[0], "darknet cfg");
      if (!cfg.ok()) return cfg.status();
      absl::StatusOr<std::string> weights = ReadModel(parts[1], "darknet weights");
      if (!weights.ok()) return weights.status();
      config.set_model_cfg(*std::move(cfg));
      config.set_model_weights(*std::move(weights));
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          "--detector '", spec, "': expected yolo:CFG,WEIGHTS (darknet) or yolo:MODEL.onnx"));
    }
  } else {
    return absl::InvalidArgumentError(absl::StrCat(
        "--detector '", spec, "': expected none, hog, yolo:CFG,WEIGHTS or yolo:MODEL.onnx"));
  }
  for (absl::string_view name : absl::StrSplit(movable, ',', absl::SkipWhitespace())) {
    config.add_movable_classes(std::string(absl::StripAsciiWhitespace(name)));
  }
  return config;
}

absl::StatusOr<v1::VisualSlamConfig::DynamicFilter> FilterFromName(const std::string& name) {
  if (name == "full") return v1::VisualSlamConfig::FILTER_FULL;
  if (name == "boxes") return v1::VisualSlamConfig::FILTER_BOXES_ONLY;
  if (name == "none") return v1::VisualSlamConfig::FILTER_NONE;
  if (name == "proven") return v1::VisualSlamConfig::FILTER_PROVEN;
  return absl::InvalidArgumentError(
      absl::StrCat("--filter '", name, "': expected full, boxes, none or proven"));
}

std::string FilterName(v1::VisualSlamConfig::DynamicFilter filter) {
  switch (filter) {
    case v1::VisualSlamConfig::FILTER_BOXES_ONLY: return "boxes";
    case v1::VisualSlamConfig::FILTER_NONE: return "none";
    case v1::VisualSlamConfig::FILTER_PROVEN: return "proven";
    default: return "full";
  }
}

absl::StatusOr<v1::CreateSessionRequest> VoSessionRequest(const VoArgs& args,
                                                          const CameraIntrinsics& camera, int width,
                                                          int height) {
  std::optional<v1::VisualSlamConfig::DynamicFilter> filter;
  if (!args.filter.empty()) {
    absl::StatusOr<v1::VisualSlamConfig::DynamicFilter> named = FilterFromName(args.filter);
    if (!named.ok()) return named.status();
    filter = *named;
  }
  absl::StatusOr<v1::DetectorConfig> detector = DetectorFromSpec(args.detector, args.movable);
  if (!detector.ok()) return detector.status();

  v1::CreateSessionRequest request;
  request.set_robot_id(args.robot_id);
  request.set_name(
      args.name.empty()
          ? absl::StrCat("vo run ", std::filesystem::path(args.sequence).filename().string())
          : args.name);
  v1::VisualSlamConfig* config = request.mutable_visual();
  v1::CameraIntrinsics* c = config->mutable_camera();
  c->set_fx(camera.fx);
  c->set_fy(camera.fy);
  c->set_cx(camera.cx);
  c->set_cy(camera.cy);
  bool distorted = false;
  for (double k : camera.distortion) distorted = distorted || k != 0;
  if (distorted) {
    for (double k : camera.distortion) c->add_distortion(k);
  }
  c->set_width(static_cast<uint32_t>(width));
  c->set_height(static_cast<uint32_t>(height));
  if (args.depth && camera.depth_scale > 0) config->set_depth_scale(camera.depth_scale);
  *config->mutable_detector() = *std::move(detector);
  // The preset fills what the flags leave unset, per input kind, on the server.
  config->set_preset(args.paper ? v1::VisualSlamConfig::PRESET_PAPER
                                : v1::VisualSlamConfig::PRESET_MEASURED_BEST);
  if (filter) config->set_filter(*filter);
  v1::VisualSlamParams* params = config->mutable_params();
  if (args.prior_direction_deg) params->set_prior_direction_deg(*args.prior_direction_deg);
  if (args.bundle_window) params->set_bundle_window(static_cast<uint32_t>(*args.bundle_window));
  if (args.relocalize) params->set_relocalization_keyframes(static_cast<uint32_t>(*args.relocalize));
  if (args.static_hamming) params->set_static_hamming_fraction(*args.static_hamming);
  if (args.proven_frames) {
    params->set_proven_static_frames(static_cast<uint32_t>(*args.proven_frames));
  }
  return request;
}

}  // namespace waymark::cli
