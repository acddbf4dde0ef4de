#include "client/datasets/euroc.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;

constexpr double kQuaternionNormTolerance = 0.1;

std::vector<absl::string_view> CsvFields(absl::string_view line) {
  std::vector<absl::string_view> fields = absl::StrSplit(line, ',');
  for (absl::string_view& f : fields) f = absl::StripAsciiWhitespace(f);
  return fields;
}

// The numbers of `key: [a, b, ...]` in the YAML text (the bracket may span lines); for T_BS the
// key is "data" after "T_BS". NOT_FOUND when the key is absent.
absl::StatusOr<std::vector<double>> BracketList(const std::string& text, const std::string& key,
                                                size_t from = 0) {
  size_t at = from;
  while (true) {
    at = text.find(key + ":", at);
    if (at == std::string::npos) {
      return absl::NotFoundError(absl::StrCat("sensor.yaml has no '", key, ":'"));
    }
    if (at == 0 || std::isspace(static_cast<unsigned char>(text[at - 1])) || text[at - 1] == '{' ||
        text[at - 1] == ',') {
      break;
    }
    at += key.size();
  }
  const size_t open = text.find('[', at);
  const size_t line_end = text.find('\n', at);
  if (open == std::string::npos || (line_end != std::string::npos && open > line_end)) {
    return absl::InvalidArgumentError(
        absl::StrCat("sensor.yaml: '", key, ":' is not a [list] on its line"));
  }
  const size_t close = text.find(']', open);
  if (close == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat("sensor.yaml: '", key, ":' has no ']'"));
  }
  std::vector<double> values;
  for (absl::string_view field :
       absl::StrSplit(text.substr(open + 1, close - open - 1), absl::ByAnyChar(", \n\t\r"),
                      absl::SkipEmpty())) {
    double v = 0;
    if (!absl::SimpleAtod(field, &v) || !std::isfinite(v)) {
      return absl::InvalidArgumentError(
          absl::StrCat("sensor.yaml: '", key, "': '", field, "' is not a number"));
    }
    values.push_back(v);
  }
  return values;
}

std::string ScalarValue(const std::string& text, const std::string& key) {
  size_t at = text.find(key + ":");
  if (at == std::string::npos) return "";
  at += key.size() + 1;
  const size_t end = text.find('\n', at);
  std::string value = text.substr(at, end == std::string::npos ? std::string::npos : end - at);
  if (const size_t hash = value.find('#'); hash != std::string::npos) value.resize(hash);
  return std::string(absl::StripAsciiWhitespace(value));
}

}  // namespace

fs::path EurocRoot(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_regular_file(dir / "mav0" / "cam0" / "data.csv", ec)) return dir / "mav0";
  if (fs::is_regular_file(dir / "cam0" / "data.csv", ec)) return dir;
  return {};
}

absl::StatusOr<EurocCamera> ParseEurocSensorYaml(const std::string& text) {
  EurocCamera camera;
  const std::string model = ScalarValue(text, "camera_model");
  if (!model.empty() && model != "pinhole") {
    return absl::InvalidArgumentError(
        absl::StrCat("sensor.yaml: camera_model '", model, "' (only pinhole is supported)"));
  }
  absl::StatusOr<std::vector<double>> k = BracketList(text, "intrinsics");
  if (!k.ok()) return k.status();
  if (k->size() != 4 || (*k)[0] <= 0 || (*k)[1] <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "sensor.yaml: intrinsics must be [fu, fv, cu, cv] with positive focal lengths; got ",
        k->size(), " numbers"));
  }
  camera.intrinsics.fx = (*k)[0];
  camera.intrinsics.fy = (*k)[1];
  camera.intrinsics.cx = (*k)[2];
  camera.intrinsics.cy = (*k)[3];
  const std::string distortion_model = ScalarValue(text, "distortion_model");
  absl::StatusOr<std::vector<double>> d = BracketList(text, "distortion_coefficients");
  if (d.ok()) {
    if (!distortion_model.empty() && distortion_model != "radial-tangential" &&
        distortion_model != "radtan" && distortion_model != "plumb_bob") {
      return absl::InvalidArgumentError(absl::StrCat(
          "sensor.yaml: distortion_model '", distortion_model,
          "' (only radial-tangential: k1, k2, p1, p2[, k3])"));
    }
    if (d->size() < 4 || d->size() > 5) {
      return absl::InvalidArgumentError(absl::StrCat(
          "sensor.yaml: distortion_coefficients must be k1, k2, p1, p2[, k3]; got ", d->size(),
          " numbers"));
    }
    std::copy(d->begin(), d->end(), camera.intrinsics.distortion.begin());
  } else if (!absl::IsNotFound(d.status())) {
    return d.status();
  }
  if (absl::StatusOr<std::vector<double>> r = BracketList(text, "resolution"); r.ok()) {
    if (r->size() != 2) {
      return absl::InvalidArgumentError("sensor.yaml: resolution must be [width, height]");
    }
    camera.width = static_cast<int>((*r)[0]);
    camera.height = static_cast<int>((*r)[1]);
  }
  if (const size_t tbs = text.find("T_BS:"); tbs != std::string::npos) {
    absl::StatusOr<std::vector<double>> m = BracketList(text, "data", tbs);
    if (!m.ok()) return m.status();
    if (m->size() != 16) {
      return absl::InvalidArgumentError(
          absl::StrCat("sensor.yaml: T_BS data must hold 16 numbers, got ", m->size()));
    }
    for (int i = 0; i < 16; ++i) camera.body_to_camera(i / 4, i % 4) = (*m)[i];
  }
  return camera;
}

bool LooksLikeEurocLine(const std::string& line) {
  if (line.find(',') == std::string::npos) return false;
  const std::vector<absl::string_view> fields = CsvFields(line);
  if (fields.size() == 17) return true;
  double stamp = 0;
  return fields.size() >= 8 && absl::SimpleAtod(fields[0], &stamp) && stamp > 1e15;
}

absl::StatusOr<std::vector<StampedPose3>> ParseEurocPoses(const std::string& text) {
  std::vector<StampedPose3> poses;
  int line_number = 0;
  for (absl::string_view raw : absl::StrSplit(text, '\n')) {
    ++line_number;
    const absl::string_view line = absl::StripAsciiWhitespace(raw);
    if (line.empty() || line[0] == '#') continue;
    const std::vector<absl::string_view> fields = CsvFields(line);
    if (fields.size() < 8) {
      return absl::InvalidArgumentError(absl::StrCat(
          "line ", line_number, ": ", fields.size(),
          " fields; expected EuRoC's timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ..."));
    }
    double v[8];
    for (int i = 0; i < 8; ++i) {
      if (!absl::SimpleAtod(fields[i], &v[i]) || !std::isfinite(v[i])) {
        return absl::InvalidArgumentError(
            absl::StrCat("line ", line_number, ": '", fields[i], "' is not a number"));
      }
    }
    Eigen::Quaterniond q(v[4], v[5], v[6], v[7]);
    if (std::abs(q.norm() - 1) > kQuaternionNormTolerance) {
      return absl::InvalidArgumentError(absl::StrCat(
          "line ", line_number, ": quaternion norm ", q.norm(),
          ", far from 1 (EuRoC's order is q_w, q_x, q_y, q_z after the position)"));
    }
    StampedPose3 pose;
    pose.stamp = v[0] * 1e-9;
    pose.rotation = q.normalized().toRotationMatrix();
    pose.translation = Eigen::Vector3d(v[1], v[2], v[3]);
    poses.push_back(pose);
  }
  if (poses.empty()) return absl::InvalidArgumentError("no poses (only blank lines and comments)");
  return poses;
}

absl::Status ReadEurocSequence(ImageSequence* sequence) {
  const fs::path root = EurocRoot(sequence->dir);
  if (root.empty()) {
    return absl::NotFoundError(
        absl::StrCat("'", sequence->dir.string(), "' has no mav0/cam0/data.csv"));
  }
  const fs::path cam = root / "cam0";
  absl::StatusOr<std::string> yaml = ReadFileBytes(cam / "sensor.yaml");
  if (!yaml.ok()) return yaml.status();
  absl::StatusOr<EurocCamera> camera = ParseEurocSensorYaml(*yaml);
  if (!camera.ok()) {
    return absl::Status(camera.status().code(),
                        absl::StrCat((cam / "sensor.yaml").string(), ": ", camera.status().message()));
  }
  sequence->intrinsics = camera->intrinsics;
  const fs::path list = cam / "data.csv";
  absl::StatusOr<std::string> csv = ReadFileBytes(list);
  if (!csv.ok()) return csv.status();
  int line_number = 0;
  std::error_code ec;
  for (absl::string_view raw : absl::StrSplit(*csv, '\n')) {
    ++line_number;
    const absl::string_view line = absl::StripAsciiWhitespace(raw);
    if (line.empty() || line[0] == '#') continue;
    const std::vector<absl::string_view> fields = CsvFields(line);
    int64_t ns = 0;
    if (fields.size() != 2 || !absl::SimpleAtoi(fields[0], &ns) || fields[1].empty()) {
      return absl::InvalidArgumentError(absl::StrCat(
          list.string(), ":", line_number, ": expected 'timestamp [ns],filename'"));
    }
    const fs::path image = cam / "data" / std::string(fields[1]);
    if (!fs::is_regular_file(image, ec)) {
      return absl::NotFoundError(
          absl::StrCat(list.string(), ":", line_number, ": no image '", image.string(), "'"));
    }
    const double stamp = static_cast<double>(ns) * 1e-9;
    if (!sequence->frames.empty() && stamp <= sequence->frames.back().stamp) {
      return absl::InvalidArgumentError(absl::StrCat(
          list.string(), ":", line_number, ": stamps must increase (", ns, " ns)"));
    }
    sequence->frames.push_back({stamp, image, std::nullopt});
  }
  if (sequence->frames.empty()) {
    return absl::NotFoundError(absl::StrCat(list.string(), " lists no images"));
  }
  const fs::path truth = root / "state_groundtruth_estimate0" / "data.csv";
  if (fs::is_regular_file(truth, ec)) sequence->groundtruth = truth;
  return absl::OkStatus();
}

}  // namespace waymark::cli
