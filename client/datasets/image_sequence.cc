#include "client/datasets/image_sequence.h"

#include "client/datasets/euroc.h"

#include "client/datasets/stamp_association.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <string>
#include <system_error>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/datasets/kitti_stamps.h"
#include "client/datasets/pose_file.h"
#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;

struct NamedCamera {
  const char* name;
  CameraIntrinsics intrinsics;
};

// Published calibrations. Depth images of the TUM benchmark and of the Bonn dataset store
// 5000 units per metre (both datasets' file format pages).
const NamedCamera kPresets[] = {
    // Bonn RGB-D Dynamic dataset page (https://www.ipb.uni-bonn.de/data/rgbd-dynamic-dataset/),
    // also ../shared/data/vslam/SOURCES.md; the images are not undistorted.
    {"bonn",
     {542.822841,
      542.576870,
      315.593520,
      237.756098,
      {0.039903, -0.099343, -0.000730, -0.000144, 0.0},
      5000}},
    // TUM RGB-D benchmark, "File Formats: intrinsic camera calibration" table
    // (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats), freiburg1, 2 and 3.
    // freiburg3 images are already undistorted (distortion zero there).
    {"tum1", {517.3, 516.5, 318.6, 255.3, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}, 5000}},
    {"tum2", {520.9, 521.0, 325.1, 249.7, {0.2312, -0.7849, -0.0033, -0.0001, 0.9172}, 5000}},
    {"tum3", {535.4, 539.2, 320.1, 247.6, {0, 0, 0, 0, 0}, 5000}},
    // KITTI odometry left gray camera P0 of sequences 04-12 (their calib.txt; 00-02 use 718.856,
    // 03 uses 721.5377): rectified images, no depth. KITTI folders carry calib.txt anyway.
    {"kitti", {707.0912, 707.0912, 601.8873, 183.1104, {0, 0, 0, 0, 0}, 0}},
};

// A whitespace-separated list line without comments; empty for a blank or comment line.
std::vector<std::string> Fields(absl::string_view line) {
  line = absl::StripAsciiWhitespace(line);
  if (line.empty() || line[0] == '#') return {};
  return absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
}

bool ParseFinite(absl::string_view text, double* value) {
  return absl::SimpleAtod(text, value) && std::isfinite(*value);
}

absl::Status ListError(const fs::path& file, int line, absl::string_view message) {
  return absl::InvalidArgumentError(absl::StrCat(file.string(), " line ", line, ": ", message));
}

// The file a list names, relative to the sequence folder; NOT_FOUND if it is missing.
absl::StatusOr<fs::path> ListedFile(const fs::path& dir, const fs::path& list, int line,
                                    const std::string& name) {
  fs::path path = fs::path(name).is_absolute() ? fs::path(name) : dir / name;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(
        absl::StrCat(list.string(), " line ", line, ": no file '", path.string(), "'"));
  }
  return path;
}

struct StampedFile {
  double stamp = 0;
  fs::path path;
  int line = 0;
};

absl::Status CheckIncreasing(const fs::path& list, const std::vector<StampedFile>& files) {
  for (size_t i = 1; i < files.size(); ++i) {
    if (!(files[i].stamp > files[i - 1].stamp)) {
      return ListError(
          list, files[i].line,
          absl::StrCat("stamp ", files[i].stamp, " does not increase (line ", files[i - 1].line,
                       " has ", files[i - 1].stamp, "); frames must be in time order"));
    }
  }
  return absl::OkStatus();
}

// Calls `frame` with each line of a frame list that is not blank or a comment, in order, after
// checking it has `field_count` fields (`usage` names them in the error). Stops at the first
// error; INVALID_ARGUMENT for a list without any frame.
absl::Status ForEachListedFrame(
    const fs::path& list, size_t field_count, absl::string_view usage,
    const std::function<absl::Status(int line, const std::vector<std::string>& fields)>& frame) {
  absl::StatusOr<std::string> text = ReadFileBytes(list);
  if (!text.ok()) return text.status();
  int line_number = 0;
  int frames = 0;
  for (absl::string_view line : absl::StrSplit(*text, '\n')) {
    ++line_number;
    const std::vector<std::string> fields = Fields(line);
    if (fields.empty()) continue;
    if (fields.size() != field_count) {
      return ListError(list, line_number,
                       absl::StrCat(fields.size(), " fields; expected ", field_count, ": ", usage));
    }
    if (absl::Status s = frame(line_number, fields); !s.ok()) return s;
    ++frames;
  }
  if (frames == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(list.string(), ": no frames (only blank lines and '#' comments)"));
  }
  return absl::OkStatus();
}

absl::Status ParseStamp(const fs::path& list, int line, const std::string& field, double* stamp) {
  if (ParseFinite(field, stamp)) return absl::OkStatus();
  return ListError(list, line, absl::StrCat("'", field, "' is not a time stamp"));
}

// rgb.txt / depth.txt: `stamp path` per line.
absl::StatusOr<std::vector<StampedFile>> ReadStampedList(const fs::path& dir,
                                                         const fs::path& list) {
  std::vector<StampedFile> files;
  absl::Status read = ForEachListedFrame(
      list, 2, "stamp path", [&](int line, const std::vector<std::string>& fields) {
        StampedFile file;
        file.line = line;
        if (absl::Status s = ParseStamp(list, line, fields[0], &file.stamp); !s.ok()) return s;
        absl::StatusOr<fs::path> path = ListedFile(dir, list, line, fields[1]);
        if (!path.ok()) return path.status();
        file.path = *std::move(path);
        files.push_back(std::move(file));
        return absl::OkStatus();
      });
  if (!read.ok()) return read;
  if (absl::Status s = CheckIncreasing(list, files); !s.ok()) return s;
  return files;
}

// associations.txt: `t_rgb rgb t_depth depth` per line.
absl::Status ReadAssociations(const fs::path& list, ImageSequence* sequence) {
  std::vector<StampedFile> rgb;
  absl::Status read = ForEachListedFrame(
      list, 4, "t_rgb rgb/x.png t_depth depth/x.png",
      [&](int line, const std::vector<std::string>& fields) {
        double t_rgb = 0;
        double t_depth = 0;
        if (absl::Status s = ParseStamp(list, line, fields[0], &t_rgb); !s.ok()) return s;
        if (absl::Status s = ParseStamp(list, line, fields[2], &t_depth); !s.ok()) return s;
        absl::StatusOr<fs::path> image = ListedFile(sequence->dir, list, line, fields[1]);
        if (!image.ok()) return image.status();
        absl::StatusOr<fs::path> depth = ListedFile(sequence->dir, list, line, fields[3]);
        if (!depth.ok()) return depth.status();
        rgb.push_back({t_rgb, *image, line});
        sequence->frames.push_back({t_rgb, *std::move(image), *std::move(depth)});
        return absl::OkStatus();
      });
  if (!read.ok()) return read;
  sequence->has_depth_list = true;
  return CheckIncreasing(list, rgb);
}

absl::Status ReadTum(ImageSequence* sequence) {
  const fs::path associations = sequence->dir / "associations.txt";
  std::error_code ec;
  if (fs::exists(associations, ec)) {
    if (absl::Status s = ReadAssociations(associations, sequence); !s.ok()) return s;
  } else {
    absl::StatusOr<std::vector<StampedFile>> rgb =
        ReadStampedList(sequence->dir, sequence->dir / "rgb.txt");
    if (!rgb.ok()) return rgb.status();
    for (const StampedFile& f : *rgb) sequence->frames.push_back({f.stamp, f.path, std::nullopt});
    const fs::path depth_list = sequence->dir / "depth.txt";
    if (fs::exists(depth_list, ec)) {
      absl::StatusOr<std::vector<StampedFile>> depth = ReadStampedList(sequence->dir, depth_list);
      if (!depth.ok()) return depth.status();
      sequence->has_depth_list = true;
      std::vector<double> rgb_stamps;
      std::vector<double> depth_stamps;
      for (const StampedFile& f : *rgb) rgb_stamps.push_back(f.stamp);
      for (const StampedFile& f : *depth) depth_stamps.push_back(f.stamp);
      for (const PoseMatch& m : AssociateByStamp(rgb_stamps, depth_stamps, kDepthPairingMaxDt)) {
        sequence->frames[m.estimate].depth = (*depth)[m.groundtruth].path;
      }
    }
  }
  if (sequence->has_depth_list) {
    for (const SequenceFrame& frame : sequence->frames) {
      if (!frame.depth) ++sequence->frames_without_depth;
    }
  }
  const fs::path groundtruth = sequence->dir / "groundtruth.txt";
  if (fs::is_regular_file(groundtruth, ec)) sequence->groundtruth = groundtruth;
  return absl::OkStatus();
}

// KITTI calib.txt: P0 (3x4, row-major) = [fx 0 cx tx; 0 fy cy ty; 0 0 1 tz].
absl::StatusOr<CameraIntrinsics> ReadKittiCalib(const fs::path& path) {
  absl::StatusOr<std::string> text = ReadFileBytes(path);
  if (!text.ok()) {
    if (absl::IsNotFound(text.status())) {
      return absl::NotFoundError(absl::StrCat(
          "no ", path.string(), ": a KITTI sequence needs calib.txt with the camera matrix P0"));
    }
    return text.status();
  }
  // The labelled line `P0: ...`, or else the first line (some copies drop the labels).
  std::vector<std::string> numbers;
  int number_line = 0;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(*text, '\n')) {
    ++line_number;
    std::vector<std::string> fields = Fields(line);
    if (fields.empty()) continue;
    if (fields[0] == "P0:") {
      numbers.assign(fields.begin() + 1, fields.end());
      number_line = line_number;
      break;
    }
    if (number_line == 0 && fields[0].back() != ':') {
      numbers = std::move(fields);
      number_line = line_number;
    }
  }
  if (number_line == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": no camera matrix P0 (a line `P0: ` + 12 numbers)"));
  }
  if (numbers.size() != 12) {
    return ListError(path, number_line,
                     absl::StrCat(numbers.size(), " numbers for P0; expected 12 (3x4 row-major)"));
  }
  double p[12];
  for (int i = 0; i < 12; ++i) {
    if (!ParseFinite(numbers[i], &p[i])) {
      return ListError(path, number_line, absl::StrCat("'", numbers[i], "' is not a number"));
    }
  }
  CameraIntrinsics intrinsics;
  intrinsics.fx = p[0];
  intrinsics.cx = p[2];
  intrinsics.fy = p[5];
  intrinsics.cy = p[6];
  if (!(intrinsics.fx > 0 && intrinsics.fy > 0)) {
    return ListError(path, number_line, "P0 has a focal length <= 0");
  }
  return intrinsics;
}

bool IsImageName(const fs::path& path) {
  const std::string ext = absl::AsciiStrToLower(path.extension().string());
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

// Stamps of KITTI frames 0..count-1: times.txt when present, else KITTI's 10 Hz (kitti_stamps.h).
absl::StatusOr<std::vector<double>> KittiStamps(const fs::path& dir, size_t count) {
  const fs::path times = dir / "times.txt";
  std::error_code ec;
  std::vector<double> stamps;
  if (fs::exists(times, ec)) {
    absl::StatusOr<std::vector<double>> read = ReadStampListFile(times);
    if (!read.ok()) return read.status();
    if (read->size() < count) {
      return absl::InvalidArgumentError(
          absl::StrCat(times.string(), ": ", read->size(), " stamps for ", count, " images"));
    }
    stamps.assign(read->begin(), read->begin() + count);
    for (size_t i = 1; i < stamps.size(); ++i) {
      if (!(stamps[i] > stamps[i - 1])) {
        return absl::InvalidArgumentError(absl::StrCat(times.string(), ": stamp ", i + 1, " (",
                                                       stamps[i], ") does not increase"));
      }
    }
    return stamps;
  }
  return DefaultKittiStamps(count);
}

absl::Status ReadKitti(ImageSequence* sequence) {
  const fs::path images = sequence->dir / "image_0";
  std::vector<fs::path> paths;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(images, ec)) {
    if (entry.is_regular_file(ec) && IsImageName(entry.path())) paths.push_back(entry.path());
  }
  if (ec) {
    return absl::PermissionDeniedError(
        absl::StrCat("cannot list ", images.string(), ": ", ec.message()));
  }
  if (paths.empty()) {
    return absl::NotFoundError(absl::StrCat(images.string(), " holds no .png or .jpg images"));
  }
  std::sort(paths.begin(), paths.end());
  absl::StatusOr<CameraIntrinsics> calib = ReadKittiCalib(sequence->dir / "calib.txt");
  if (!calib.ok()) return calib.status();
  sequence->intrinsics = *calib;
  absl::StatusOr<std::vector<double>> stamps = KittiStamps(sequence->dir, paths.size());
  if (!stamps.ok()) return stamps.status();
  for (size_t i = 0; i < paths.size(); ++i) {
    sequence->frames.push_back({(*stamps)[i], paths[i], std::nullopt});
  }
  const fs::path poses = sequence->dir / "poses.txt";
  if (fs::is_regular_file(poses, ec)) sequence->groundtruth = poses;
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<CameraIntrinsics> CameraPreset(absl::string_view name) {
  for (const NamedCamera& preset : kPresets) {
    if (name == preset.name) return preset.intrinsics;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown camera '", name, "' (presets: ", CameraPresetNames(), ")"));
}

std::string CameraPresetNames() {
  std::vector<std::string> names;
  for (const NamedCamera& preset : kPresets) names.push_back(preset.name);
  return absl::StrJoin(names, ", ");
}

absl::StatusOr<std::array<double, 5>> ParseDistortion(absl::string_view text) {
  const std::vector<std::string> fields = absl::StrSplit(text, ',');
  if (fields.size() != 4 && fields.size() != 5) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--distortion '", text, "': expected 4 or 5 comma-separated numbers k1,k2,p1,p2[,k3]"));
  }
  std::array<double, 5> values{};
  for (size_t i = 0; i < fields.size(); ++i) {
    if (!ParseFinite(absl::StripAsciiWhitespace(fields[i]), &values[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat("--distortion '", text, "': '", fields[i], "' is not a number"));
    }
  }
  return values;
}

const char* SequenceLayoutName(SequenceLayout layout) {
  switch (layout) {
    case SequenceLayout::kKitti:
      return "kitti";
    case SequenceLayout::kEuroc:
      return "euroc";
    case SequenceLayout::kTum:
      break;
  }
  return "tum";
}

absl::StatusOr<ImageSequence> ReadImageSequence(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat("no folder '", dir.string(), "'"));
  }
  ImageSequence sequence;
  sequence.dir = dir;
  if (fs::exists(dir / "associations.txt", ec) || fs::exists(dir / "rgb.txt", ec)) {
    sequence.layout = SequenceLayout::kTum;
    if (absl::Status s = ReadTum(&sequence); !s.ok()) return s;
  } else if (fs::is_directory(dir / "image_0", ec)) {
    sequence.layout = SequenceLayout::kKitti;
    if (absl::Status s = ReadKitti(&sequence); !s.ok()) return s;
  } else if (!EurocRoot(dir).empty()) {
    sequence.layout = SequenceLayout::kEuroc;
    if (absl::Status s = ReadEurocSequence(&sequence); !s.ok()) return s;
  } else {
    return absl::NotFoundError(absl::StrCat(
        "'", dir.string(),
        "' is not an image sequence: expected rgb.txt or associations.txt (TUM layout) or "
        "image_0/ with calib.txt (KITTI layout) or mav0/cam0/data.csv (EuRoC layout)"));
  }
  return sequence;
}

absl::StatusOr<std::vector<StampedPose3>> ReadSequenceGroundTruth(const ImageSequence& sequence) {
  if (!sequence.groundtruth) {
    return absl::NotFoundError(
        absl::StrCat("'", sequence.dir.string(), "' has no groundtruth.txt or poses.txt"));
  }
  PoseFileOptions options;
  if (sequence.layout == SequenceLayout::kEuroc) {
    // The body's poses; the camera's are body * T_BS (cam0/sensor.yaml).
    absl::StatusOr<PoseFile> file = ReadPoseFile(*sequence.groundtruth, {PoseFormat::kEuroc, {}});
    if (!file.ok()) return file.status();
    Eigen::Matrix4d body_to_camera = Eigen::Matrix4d::Identity();
    if (absl::StatusOr<std::string> yaml =
            ReadFileBytes(EurocRoot(sequence.dir) / "cam0" / "sensor.yaml");
        yaml.ok()) {
      if (absl::StatusOr<EurocCamera> camera = ParseEurocSensorYaml(*yaml); camera.ok()) {
        body_to_camera = camera->body_to_camera;
      }
    }
    const Eigen::Matrix3d r = body_to_camera.topLeftCorner<3, 3>();
    const Eigen::Vector3d t = body_to_camera.topRightCorner<3, 1>();
    for (StampedPose3& pose : file->poses) {
      pose.translation = pose.rotation * t + pose.translation;
      pose.rotation = pose.rotation * r;
    }
    return std::move(file->poses);
  }
  if (sequence.layout == SequenceLayout::kKitti) {
    options.format = PoseFormat::kKitti;
    // One pose per line: count them to give each the frames' stamp rule.
    absl::StatusOr<std::string> text = ReadFileBytes(*sequence.groundtruth);
    if (!text.ok()) return text.status();
    size_t count = 0;
    for (absl::string_view line : absl::StrSplit(*text, '\n')) {
      if (!Fields(line).empty()) ++count;
    }
    absl::StatusOr<std::vector<double>> stamps = KittiStamps(sequence.dir, count);
    if (!stamps.ok()) return stamps.status();
    options.kitti_stamps = *std::move(stamps);
  } else {
    options.format = PoseFormat::kTum;
  }
  absl::StatusOr<PoseFile> file = ReadPoseFile(*sequence.groundtruth, options);
  if (!file.ok()) return file.status();
  return std::move(file->poses);
}

}  // namespace waymark::cli
