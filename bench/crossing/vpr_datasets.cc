#include "bench/crossing/vpr_datasets.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace waymark::vpr {
namespace {

namespace fs = std::filesystem;

absl::Status RequireDir(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat("folder ", dir, " does not exist"));
  }
  return absl::OkStatus();
}

absl::Status RequireFile(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("file ", path, " does not exist"));
  }
  return absl::OkStatus();
}

// Files of `dir` with extension `ext` (".jpg"), sorted by name.
std::vector<std::string> ListFiles(const std::string& dir, const std::string& ext) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.is_regular_file() && entry.path().extension() == ext) {
      out.push_back(entry.path().string());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> SplitOn(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(s);
  while (std::getline(in, item, sep)) out.push_back(item);
  return out;
}

std::string Trim(std::string s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\n')) s.pop_back();
  size_t start = 0;
  while (start < s.size() && s[start] == ' ') ++start;
  return s.substr(start);
}

// Unit quaternion (x, y, z, w) to a rotation matrix.
cv::Matx33d QuaternionToMatrix(double x, double y, double z, double w) {
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  if (n > 0) {
    x /= n;
    y /= n;
    z /= n;
    w /= n;
  }
  return cv::Matx33d(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                     2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                     2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y));
}

}  // namespace

DataPaths DefaultDataPaths(const std::string& shared_dir) {
  DataPaths p;
  p.corridor = shared_dir + "/data/vpr/corridor_vprbench";
  p.triplets = shared_dir + "/data/vpr/gardenspoint_sfu_triplets_sample";
  p.kitti = shared_dir + "/data/vslam/kitti_odom06_frames000-050";
  p.bonn = shared_dir + "/data/vslam/bonn_rgbd_crowd_frames270-409";
  return p;
}

absl::StatusOr<CorridorSet> LoadCorridor(const std::string& dir) {
  if (auto s = RequireDir(dir); !s.ok()) return s;
  CorridorSet set;
  set.refs = ListFiles(dir + "/ref", ".jpg");
  set.queries = ListFiles(dir + "/query", ".jpg");
  if (set.refs.empty() || set.queries.empty()) {
    return absl::NotFoundError(absl::StrCat(dir, " has no ref/*.jpg or query/*.jpg images"));
  }
  const std::string gt_path = dir + "/ground_truth.csv";
  if (auto s = RequireFile(gt_path); !s.ok()) return s;
  std::ifstream in(gt_path);
  std::string line;
  std::getline(in, line);  // header
  set.ground_truth.assign(set.queries.size(), {});
  int rows = 0;
  while (std::getline(in, line)) {
    line = Trim(line);
    if (line.empty()) continue;
    const std::vector<std::string> fields = SplitOn(line, ',');
    if (fields.size() != 2) {
      return absl::InvalidArgumentError(absl::StrCat(gt_path, ": malformed line '", line, "'"));
    }
    const int q = std::atoi(fields[0].c_str());
    if (q < 0 || q >= static_cast<int>(set.queries.size())) {
      return absl::InvalidArgumentError(
          absl::StrCat(gt_path, ": query index ", q, " out of range"));
    }
    std::istringstream refs(fields[1]);
    int r;
    while (refs >> r) {
      if (r < 0 || r >= static_cast<int>(set.refs.size())) {
        return absl::InvalidArgumentError(
            absl::StrCat(gt_path, ": ref index ", r, " out of range"));
      }
      set.ground_truth[q].push_back(r);
    }
    ++rows;
  }
  if (rows != static_cast<int>(set.queries.size())) {
    return absl::InvalidArgumentError(
        absl::StrCat(gt_path, " has ", rows, " rows for ", set.queries.size(), " queries"));
  }
  return set;
}

absl::StatusOr<TripletSet> LoadTriplets(const std::string& dir) {
  if (auto s = RequireDir(dir); !s.ok()) return s;
  const std::string manifest = dir + "/manifest.csv";
  if (auto s = RequireFile(manifest); !s.ok()) return s;
  std::ifstream in(manifest);
  std::string line;
  std::getline(in, line);  // place,slot,file,...
  std::map<int, std::map<int, std::string>> by_place;
  while (std::getline(in, line)) {
    line = Trim(line);
    if (line.empty()) continue;
    const std::vector<std::string> f = SplitOn(line, ',');
    if (f.size() < 3 || f[0].size() < 2 || f[1].size() < 2 || f[0][0] != 'p' || f[1][0] != 'i') {
      return absl::InvalidArgumentError(absl::StrCat(manifest, ": malformed line '", line, "'"));
    }
    const std::string path = dir + "/" + f[2];
    if (auto s = RequireFile(path); !s.ok()) return s;
    by_place[std::atoi(f[0].c_str() + 1)][std::atoi(f[1].c_str() + 1)] = path;
  }
  TripletSet set;
  int expected = 0;
  for (const auto& [place, slots] : by_place) {
    if (place != expected++) {
      return absl::InvalidArgumentError(absl::StrCat(manifest, ": places are not p0..pN"));
    }
    std::vector<std::string> images;
    for (const auto& [slot, path] : slots) images.push_back(path);
    set.images.push_back(std::move(images));
  }
  if (set.images.empty()) return absl::NotFoundError(absl::StrCat(manifest, " lists no images"));
  return set;
}

absl::StatusOr<FrameSequence> LoadKittiFrames(const std::string& dir) {
  if (auto s = RequireDir(dir); !s.ok()) return s;
  const std::vector<std::string> images = ListFiles(dir + "/image_0", ".png");
  const std::string poses_path = dir + "/poses.txt";
  if (auto s = RequireFile(poses_path); !s.ok()) return s;
  std::ifstream in(poses_path);
  std::string line;
  FrameSequence seq;
  seq.name = "kitti06";
  while (std::getline(in, line)) {
    std::istringstream row(line);
    double m[12];
    int n = 0;
    while (n < 12 && row >> m[n]) ++n;
    if (n == 0) continue;
    if (n != 12) {
      return absl::InvalidArgumentError(
          absl::StrCat(poses_path, ": a pose line has ", n, " numbers, expected 12"));
    }
    PosedFrame frame;
    frame.index = static_cast<int>(seq.frames.size());
    frame.timestamp = frame.index / 10.0;
    frame.rotation = cv::Matx33d(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    frame.position = cv::Vec3d(m[3], m[7], m[11]);
    seq.frames.push_back(frame);
  }
  if (images.size() != seq.frames.size() || images.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(dir, ": ", images.size(), " images but ", seq.frames.size(), " poses"));
  }
  for (size_t i = 0; i < images.size(); ++i) seq.frames[i].path = images[i];
  return seq;
}

absl::StatusOr<FrameSequence> LoadBonnFrames(const std::string& dir) {
  if (auto s = RequireDir(dir); !s.ok()) return s;
  const std::string list_path = dir + "/rgb.txt";
  const std::string gt_path = dir + "/groundtruth.txt";
  if (auto s = RequireFile(list_path); !s.ok()) return s;
  if (auto s = RequireFile(gt_path); !s.ok()) return s;

  struct GtPose {
    double t;
    cv::Vec3d p;
    double qx, qy, qz, qw;
  };
  std::vector<GtPose> gt;
  {
    std::ifstream in(gt_path);
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream row(line);
      GtPose g;
      if (!(row >> g.t >> g.p[0] >> g.p[1] >> g.p[2] >> g.qx >> g.qy >> g.qz >> g.qw)) {
        return absl::InvalidArgumentError(absl::StrCat(gt_path, ": malformed line '", line, "'"));
      }
      gt.push_back(g);
    }
  }
  std::sort(gt.begin(), gt.end(), [](const GtPose& a, const GtPose& b) { return a.t < b.t; });
  if (gt.size() < 2) return absl::InvalidArgumentError(absl::StrCat(gt_path, " has < 2 poses"));

  FrameSequence seq;
  seq.name = "bonn_crowd";
  std::ifstream in(list_path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream row(line);
    double t;
    std::string file;
    if (!(row >> t >> file)) continue;
    if (t < gt.front().t || t > gt.back().t) continue;  // no ground truth for this frame
    auto after = std::lower_bound(gt.begin(), gt.end(), t,
                                  [](const GtPose& g, double v) { return g.t < v; });
    if (after == gt.begin()) ++after;
    auto before = after - 1;
    const double span = after->t - before->t;
    const double w = span > 0 ? (t - before->t) / span : 0.0;
    const GtPose& nearest = (t - before->t) <= (after->t - t) ? *before : *after;
    PosedFrame frame;
    frame.path = dir + "/" + file;
    if (auto s = RequireFile(frame.path); !s.ok()) return s;
    frame.index = static_cast<int>(seq.frames.size());
    frame.timestamp = t;
    frame.position = before->p * (1.0 - w) + after->p * w;
    frame.rotation = QuaternionToMatrix(nearest.qx, nearest.qy, nearest.qz, nearest.qw);
    seq.frames.push_back(frame);
  }
  if (seq.frames.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(list_path, ": no frame within the ground truth"));
  }
  return seq;
}

double RotationAngleDeg(const cv::Matx33d& a, const cv::Matx33d& b) {
  const cv::Matx33d r = a.t() * b;
  const double c = std::clamp((r(0, 0) + r(1, 1) + r(2, 2) - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

}  // namespace waymark::vpr
