// waymark-map-check: the map self-check (server/laser_slam/mapping/map_consistency.h) on the nodes
// of a map waymark-laser-eval saved (--save-nodes), with other settings: the check's limits are
// calibrated and its cost measured without running SLAM again.
//
//   waymark-map-check (--nodes FILE | --log LOG) [--fold FRACTION,DEGREES] [--opt NAME=VALUE ...]
//                     [--repeat N] [--out DIR] [--view XMIN,YMIN,XMAX,YMAX]
//                     [--picture FILE.png [--picture-size N]]
//
// --log LOG: the map a log's own laser poses make, no SLAM: for the GMapping-corrected logs of
// ../shared (*-corrected.log.gz) a map believed consistent, on which the check must not find
// contradictions. A node every 0.25 m / 0.15 rad (MappingOptions' default node_travel /
// node_turn), its returns within 12 m thinned to one per 5 cm (point_range / point_cell), in
// groups of 25 nodes (submap_nodes), as the back end keeps them.
// --fold FRACTION,DEGREES: the nodes from FRACTION of the way on rotated by DEGREES about the
// first of them, as a wrong loop closure folds a map: a check that passes the map must fail this.
//
// Prints the self_check JSON of summary.json (check_ms: the fastest of --repeat runs);
// --out DIR writes DIR/occupancy.png with the contradicting cells in red (only the --view
// rectangle of the map frame, enlarged, when given); --picture FILE.png the small palette picture
// of waymark-laser-eval --picture (longer side --picture-size pixels, default 360).

#include <algorithm>
#include <cmath>
#include <memory>
#include <chrono>
#include <cstdio>
#include <optional>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

#include "bench/laser/laser_map_check.h"
#include "client/datasets/carmen_log.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/point_cloud.h"

namespace waymark::bench {
namespace {

namespace ls = waymark::laser_slam;

// --opt NAME=VALUE: one MapConsistencyOptions field by name.
bool SetCheckOption(const std::string& assignment, ls::MapConsistencyOptions* o) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos) return false;
  const std::string name = assignment.substr(0, eq);
  const double value = std::stod(assignment.substr(eq + 1));
  const std::map<std::string, double*> doubles = {
      {"resolution", &o->resolution}, {"tolerance", &o->tolerance},
      {"tile_size", &o->tile_size},   {"tile_limit", &o->tile_limit},
      {"min_structure_length", &o->min_structure_length},
      {"map_limit", &o->map_limit}};
  const std::map<std::string, int*> ints = {
      {"neighbour_submaps", &o->neighbour_submaps},
      {"min_hits", &o->min_hits},
      {"min_mutual_cells", &o->min_mutual_cells},
      {"map_min_tiles", &o->map_min_tiles},
      {"tile_min_contradicted", &o->tile_min_contradicted}};
  if (auto it = doubles.find(name); it != doubles.end()) {
    *it->second = value;
    return true;
  }
  if (auto it = ints.find(name); it != ints.end()) {
    *it->second = static_cast<int>(value);
    return true;
  }
  return false;
}

// Nodes from the laser poses of a CARMEN log (see the file comment).
absl::StatusOr<SavedNodes> NodesFromLog(const std::string& path) {
  absl::StatusOr<std::unique_ptr<adapters::CarmenLogReader>> reader =
      adapters::CarmenLogReader::Open(path);
  if (!reader.ok()) return reader.status();
  const ls::MappingOptions defaults;
  SavedNodes saved;
  saved.submap_nodes = defaults.submap_nodes;
  adapters::CarmenRecord record;
  ls::Pose2 last;
  while (true) {
    absl::StatusOr<bool> more = (*reader)->Next(&record);
    if (!more.ok()) return more.status();
    if (!*more) break;
    if (record.type != adapters::CarmenRecord::Type::kLaser) continue;
    const adapters::CarmenLaser& laser = record.laser;
    const ls::Pose2 pose{laser.laser_pose.x, laser.laser_pose.y, laser.laser_pose.theta};
    if (!saved.nodes.empty() &&
        std::hypot(pose.x - last.x, pose.y - last.y) < defaults.node_travel &&
        std::abs(std::remainder(pose.theta - last.theta, 2 * M_PI)) < defaults.node_turn) {
      continue;
    }
    const ls::LaserScan scan = ToLaserScan(laser);
    ls::NodeView node;
    node.scan = saved.nodes.size() + 1;
    node.stamp = laser.stamp;
    node.global = pose;
    node.points = std::make_shared<const ls::PointCloud>(ls::ThinPoints(
        ls::ScanToPoints(scan, ls::Pose2{}, 0.05, defaults.point_range), defaults.point_cell));
    saved.nodes.push_back(std::move(node));
    last = pose;
  }
  return saved;
}

// Nodes [first, end) rotated by `angle` about node `first`'s position.
void Fold(std::vector<ls::NodeView>& nodes, size_t first, double angle) {
  if (first >= nodes.size()) return;
  const double px = nodes[first].global.x, py = nodes[first].global.y;
  const double c = std::cos(angle), s = std::sin(angle);
  for (size_t i = first; i < nodes.size(); ++i) {
    ls::Pose2& p = nodes[i].global;
    const double dx = p.x - px, dy = p.y - py;
    p = {px + c * dx - s * dy, py + s * dx + c * dy, p.theta + angle};
  }
}

int Run(int argc, char** argv) {
  std::string nodes_path, log_path, out, picture;
  int picture_size = 360;
  double fold_fraction = -1.0, fold_degrees = 0.0;
  std::optional<PictureView> view;
  int repeat = 1;
  ls::MapConsistencyOptions options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    try {
      if (a == "--nodes") {
        nodes_path = v;
      } else if (a == "--log") {
        log_path = v;
      } else if (a == "--fold") {
        if (std::sscanf(v.c_str(), "%lf,%lf", &fold_fraction, &fold_degrees) != 2 ||
            !(fold_fraction >= 0.0 && fold_fraction < 1.0)) {
          throw std::invalid_argument(v);
        }
      } else if (a == "--repeat") {
        repeat = std::max(1, std::stoi(v));
      } else if (a == "--view") {
        PictureView v4;
        if (std::sscanf(v.c_str(), "%lf,%lf,%lf,%lf", &v4.min.x, &v4.min.y, &v4.max.x,
                        &v4.max.y) != 4) {
          throw std::invalid_argument(v);
        }
        view = v4;
      } else if (a == "--out") {
        out = v;
      } else if (a == "--picture") {
        picture = v;
      } else if (a == "--picture-size") {
        picture_size = std::stoi(v);
        if (picture_size < 16 || picture_size > 4000) throw std::invalid_argument(v);
      } else if (a == "--opt") {
        if (!SetCheckOption(v, &options)) throw std::invalid_argument(v);
      } else {
        std::cerr << "unknown option " << a << "\n";
        return 2;
      }
    } catch (...) {
      std::cerr << "bad value for " << a << ": " << v << "\n";
      return 2;
    }
  }
  if (nodes_path.empty() == log_path.empty() || argc % 2 == 0) {
    std::cerr << "usage: waymark-map-check (--nodes FILE | --log LOG) [--fold FRACTION,DEGREES]\n"
                 "                         [--opt NAME=VALUE ...] [--repeat N] [--out DIR]\n"
                 "                         [--view XMIN,YMIN,XMAX,YMAX]\n"
                 "                         [--picture FILE.png [--picture-size N]]\n";
    return 2;
  }
  absl::StatusOr<SavedNodes> saved =
      log_path.empty() ? ReadNodesFile(nodes_path) : NodesFromLog(log_path);
  if (!saved.ok()) {
    std::cerr << saved.status() << "\n";
    return 1;
  }
  if (fold_fraction >= 0.0) {
    Fold(saved->nodes, static_cast<size_t>(fold_fraction * saved->nodes.size()),
         fold_degrees * M_PI / 180.0);
  }
  const std::vector<ls::NodeView>& nodes = saved->nodes;
  options.submap_nodes = saved->submap_nodes;
  MapCheck check;
  check.options = options;
  check.check_ms = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    absl::StatusOr<ls::MapConsistencyReport> report = ls::CheckMapConsistency(nodes, options);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!report.ok()) {
      std::cerr << report.status() << "\n";
      return 1;
    }
    check.check_ms = std::min(check.check_ms, ms);
    check.report = *std::move(report);
  }
  std::cout << MapCheckJson(check).dump(2) << "\n";
  if (!out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(out, ec);
    std::vector<cli::Vec2> path;
    for (const ls::NodeView& n : nodes) path.push_back({n.global.x, n.global.y});
    if (absl::Status s = WriteCheckedOccupancyPicture(std::filesystem::path(out) / "occupancy.png",
                                                      nodes, check, path, 0.05, view);
        !s.ok()) {
      std::cerr << s << "\n";
      return 1;
    }
  }
  if (!picture.empty()) {
    if (absl::Status s = WriteSmallCheckedPicture(picture, nodes, check, picture_size);
        !s.ok()) {
      std::cerr << s << "\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) { return waymark::bench::Run(argc, argv); }
