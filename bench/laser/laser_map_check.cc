#include "bench/laser/laser_map_check.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <memory>
#include <numeric>
#include <string>

#include <opencv2/imgproc.hpp>

#include "absl/strings/str_format.h"
#include "bench/common/bench_timing.h"
#include "client/render/occupancy_picture.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
#include "server/service/slam/map_self_check.h"
#include "server/service/slam/slam_params.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::bench {

laser_slam::LaserScan ToLaserScan(const adapters::CarmenLaser& laser) {
  laser_slam::LaserScan scan;
  scan.stamp = laser.stamp;
  scan.geometry.angle_min = laser.angle_min;
  scan.geometry.angle_increment = laser.angle_increment;
  scan.geometry.beam_count = static_cast<int>(laser.ranges.size());
  scan.geometry.no_return_range = laser.no_return_range;
  scan.ranges = laser.ranges;
  return scan;
}

namespace {

namespace ls = waymark::laser_slam;

// The pictures stay readable and small enough to open: at most this many cells a side (a 4000 px
// picture of Killian's 200 m rather than 4 GB of 5 cm cells).
constexpr std::int64_t kPictureCells = 16'000'000;


}  // namespace

// Loop closures whose relative pose disagrees with the final graph by more than 0.3 m or 3 deg
// ("false": the optimum, held by all other constraints, does not agree with them).
nlohmann::json MappingJson(const ls::MappingBackend& backend) {
  const ls::MappingStats stats = backend.Stats();
  const std::vector<ls::NodeView> nodes = backend.Nodes();
  int loops = 0, enabled = 0, disagreeing = 0;
  for (const ls::GraphConstraint& c : backend.Constraints()) {
    if (c.kind != ls::GraphConstraint::Kind::kLoop) continue;
    ++loops;
    if (!c.enabled) continue;
    ++enabled;
    const ls::Pose2 a = nodes[c.from].global, b = nodes[c.to].global;
    const double ca = std::cos(a.theta), sa = std::sin(a.theta);
    const double dx = ca * (b.x - a.x) + sa * (b.y - a.y) - c.relative.x;
    const double dy = -sa * (b.x - a.x) + ca * (b.y - a.y) - c.relative.y;
    const double dt = std::remainder(b.theta - a.theta - c.relative.theta, 2 * M_PI);
    if (std::hypot(dx, dy) > 0.3 || std::abs(dt) > 3.0 * M_PI / 180.0) ++disagreeing;
  }
  return {{"nodes", stats.nodes},
          {"submaps", stats.submaps},
          {"submaps_pruned", stats.submaps_pruned},
          {"nodes_pruned", stats.nodes_pruned},
          {"graph_nodes", stats.graph_nodes},
          {"searches", stats.searches},
          {"candidates", stats.candidates},
          {"closures_accepted", stats.closures_accepted},
          {"closures_rejected", stats.closures_rejected},
          {"closures_switched_off", stats.closures_switched_off},
          {"closures_ambiguous", stats.closures_ambiguous},
          {"closures_loosened", stats.closures_loosened},
          {"closures_where_seen", stats.closures_where_seen},
          {"closures_pending", stats.closures_pending},
          {"closures_unconfirmed", stats.closures_unconfirmed},
          {"global_searches", stats.global_searches},
          {"closures_in_graph", enabled},
          {"closures_disagreeing_with_final_graph", disagreeing},
          {"optimizations", stats.optimizations},
          {"local_matches", stats.local_matches},
          {"local_unmatched", stats.local_unmatched},
          {"local_odometry_wins", stats.local_odometry_wins},
          {"local_widened", stats.local_widened},
          {"local_unmatched_odometry", stats.local_unmatched_odometry},
          {"local_ekf_trusted", stats.local_ekf_trusted},
          {"local_ekf_redecided", stats.local_ekf_redecided},
          {"local_edge_translations_dropped", stats.local_edge_translations_dropped},
          {"local_s_total", std::accumulate(stats.local_ms.begin(), stats.local_ms.end(), 0.0) / 1000},
          {"search_s_total", std::accumulate(stats.search_ms.begin(), stats.search_ms.end(), 0.0) / 1000},
          {"optimize_s_total",
           std::accumulate(stats.optimize_ms.begin(), stats.optimize_ms.end(), 0.0) / 1000},
          {"search_ms_p50", Percentile(stats.search_ms, 0.5)},
          {"search_ms_p99", Percentile(stats.search_ms, 0.99)},
          {"optimize_ms_p50", Percentile(stats.optimize_ms, 0.5)},
          {"optimize_ms_p99", Percentile(stats.optimize_ms, 0.99)}};
}

namespace {
constexpr char kNodesMagic[8] = {'W', 'M', 'N', 'O', 'D', 'E', 'S', '1'};

template <typename T>
void Put(std::ofstream& out, const T& value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof value);
}
template <typename T>
bool Get(std::ifstream& in, T* value) {
  return static_cast<bool>(in.read(reinterpret_cast<char*>(value), sizeof *value));
}
}  // namespace

absl::Status WriteNodesFile(const std::filesystem::path& path,
                            const std::vector<ls::NodeView>& nodes, int submap_nodes) {
  std::ofstream out(path, std::ios::binary);
  out.write(kNodesMagic, sizeof kNodesMagic);
  Put(out, static_cast<std::int32_t>(submap_nodes));
  Put(out, static_cast<std::uint64_t>(nodes.size()));
  for (const ls::NodeView& n : nodes) {
    Put(out, n.scan);
    Put(out, n.stamp);
    Put(out, n.global);
    const std::uint32_t count = n.points == nullptr ? 0 : n.points->size();
    Put(out, count);
    if (count > 0) {
      out.write(reinterpret_cast<const char*>(n.points->data()),
                static_cast<std::streamsize>(count * sizeof(Eigen::Vector2f)));
    }
  }
  if (!out) return absl::PermissionDeniedError("cannot write " + path.string());
  return absl::OkStatus();
}

absl::Status WriteClosuresFile(const std::filesystem::path& path,
                               const std::vector<ls::NodeView>& nodes,
                               const std::vector<ls::GraphConstraint>& constraints) {
  std::ofstream out(path);
  out << "# from_stamp to_stamp x y theta sigma_x sigma_y sigma_theta enabled score\n";
  const int n = static_cast<int>(nodes.size());
  for (const ls::GraphConstraint& c : constraints) {
    if (c.kind != ls::GraphConstraint::Kind::kLoop) continue;
    if (c.from < 0 || c.from >= n || c.to < 0 || c.to >= n) continue;
    out << absl::StrFormat("%.6f %.6f %.4f %.4f %.5f %.4f %.4f %.5f %d %.3f\n",
                           nodes[c.from].stamp, nodes[c.to].stamp, c.relative.x, c.relative.y,
                           c.relative.theta, c.sigma.x(), c.sigma.y(), c.sigma.z(),
                           c.enabled ? 1 : 0, c.score);
  }
  if (!out) return absl::PermissionDeniedError("cannot write " + path.string());
  return absl::OkStatus();
}

absl::StatusOr<SavedNodes> ReadNodesFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError("cannot open " + path.string());
  char magic[sizeof kNodesMagic];
  std::int32_t submap_nodes = 0;
  std::uint64_t count = 0;
  if (!in.read(magic, sizeof magic) || !std::equal(magic, magic + sizeof magic, kNodesMagic) ||
      !Get(in, &submap_nodes) || !Get(in, &count) || submap_nodes < 1 || count > (1u << 24)) {
    return absl::DataLossError(path.string() + ": not a nodes file of waymark-laser-eval");
  }
  SavedNodes saved;
  saved.submap_nodes = submap_nodes;
  for (std::uint64_t i = 0; i < count; ++i) {
    ls::NodeView n;
    std::uint32_t points = 0;
    if (!Get(in, &n.scan) || !Get(in, &n.stamp) || !Get(in, &n.global) || !Get(in, &points) ||
        points > (1u << 20)) {
      return absl::DataLossError(path.string() + ": truncated at node " + std::to_string(i));
    }
    ls::PointCloud cloud(points);
    if (points > 0 && !in.read(reinterpret_cast<char*>(cloud.data()),
                               static_cast<std::streamsize>(points * sizeof(Eigen::Vector2f)))) {
      return absl::DataLossError(path.string() + ": truncated at node " + std::to_string(i));
    }
    n.points = std::make_shared<const ls::PointCloud>(std::move(cloud));
    saved.nodes.push_back(std::move(n));
  }
  return saved;
}

absl::StatusOr<MapCheck> RunMapCheck(const std::vector<ls::NodeView>& nodes, int submap_nodes) {
  MapCheck check;
  check.options.submap_nodes = submap_nodes;
  const auto start = std::chrono::steady_clock::now();
  absl::StatusOr<ls::MapConsistencyReport> report = ls::CheckMapConsistency(nodes, check.options);
  check.check_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!report.ok()) return report.status();
  check.report = *std::move(report);
  return check;
}

OptimisationChecks::OptimisationChecks(int submap_nodes, bool incremental)
    : incremental_(incremental) {
  options_.submap_nodes = submap_nodes;
  checker_ = std::make_unique<ls::MapConsistencyChecker>(options_);
}

absl::Status OptimisationChecks::AfterScan(const ls::MappingBackend& backend) {
  const std::uint64_t revision = backend.revision();
  if (revision == revision_) return absl::OkStatus();
  revision_ = revision;
  const auto start = std::chrono::steady_clock::now();
  if (!incremental_) checker_ = std::make_unique<ls::MapConsistencyChecker>(options_);
  absl::StatusOr<ls::MapConsistencyReport> report = checker_->Check(backend.Nodes());
  ms_.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  if (!report.ok()) return report.status();
  submaps_cast_ += report->submaps_cast;
  submaps_seen_ += report->submaps;
  failing_ += report->consistent ? 0 : 1;
  return absl::OkStatus();
}

nlohmann::json OptimisationChecks::Json() const {
  return {{"incremental", incremental_},
          {"checks", ms_.size()},
          {"checks_failing", failing_},
          {"ms_p50", Percentile(ms_, 0.5)},
          {"ms_p99", Percentile(ms_, 0.99)},
          {"ms_max", ms_.empty() ? 0.0 : *std::max_element(ms_.begin(), ms_.end())},
          {"s_total", std::accumulate(ms_.begin(), ms_.end(), 0.0) / 1000},
          {"submaps_cast_fraction",
           submaps_seen_ > 0 ? double(submaps_cast_) / submaps_seen_ : 0.0}};
}

nlohmann::json MapCheckJson(const MapCheck& check) {
  const ls::MapConsistencyReport& r = check.report;
  const ls::MapConsistencyOptions& o = check.options;
  nlohmann::json tiles = nlohmann::json::array();
  for (const ls::ConsistencyTile& t : r.tiles) {
    if (t.confirmed + t.contradicted + t.one_sided + t.stray == 0) continue;
    tiles.push_back({{"min", {t.min.x(), t.min.y()}},
                     {"size_m", t.size},
                     {"points", t.points},
                     {"confirmed", t.confirmed},
                     {"contradicted", t.contradicted},
                     {"one_sided", t.one_sided},
                     {"stray", t.stray},
                     {"fraction", t.fraction},
                     {"contradicts", t.contradicts}});
  }
  return {{"consistent", r.consistent},
          {"verdict", r.verdict},
          {"fraction", r.fraction},
          {"baseline_fraction", r.baseline_fraction},
          {"confirmed", r.confirmed},
          {"contradicted", r.contradicted},
          {"one_sided", r.one_sided},
          {"stray", r.stray},
          {"disagreeing_submap_pairs", r.disagreeing_pairs},
          {"contradicting_cells", r.contradicting_cells.size()},
          {"tiles_contradicting", r.tiles_contradicting},
          {"worst_tile_fraction", r.worst_tile_fraction},
          {"nodes", r.nodes},
          {"submaps", r.submaps},
          {"resolution_m", r.resolution},
          {"check_ms", check.check_ms},
          {"limits",
           {{"map_fraction", o.map_limit},
            {"map_min_tiles", o.map_min_tiles},
            {"tile_fraction", o.tile_limit},
            {"tile_min_contradicted", o.tile_min_contradicted},
            {"tile_size_m", o.tile_size},
            {"tolerance_m", o.tolerance},
            {"min_structure_length_m", o.min_structure_length},
            {"min_mutual_cells", o.min_mutual_cells},
            {"neighbour_submaps", o.neighbour_submaps}}},
          {"tiles", tiles}};
}

std::vector<cli::ScenePolyline> ContradictionPolylines(const MapCheck& check) {
  std::vector<cli::ScenePolyline> marks;
  const double half = check.report.resolution / 2;
  for (const Eigen::Vector2d& c : check.report.contradicting_cells) {
    cli::ScenePolyline mark;
    mark.color = {220, 20, 20};
    mark.width_px = 2.0;
    mark.points = {{c.x() - half, c.y()}, {c.x() + half, c.y()}};
    if (marks.empty()) mark.label = "contradicting cells (self-check)";
    marks.push_back(std::move(mark));
  }
  return marks;
}

absl::Status WriteCheckedOccupancyPicture(const std::filesystem::path& path,
                                          const std::vector<ls::NodeView>& nodes,
                                          const MapCheck& check,
                                          const std::vector<cli::Vec2>& trajectory,
                                          double resolution,
                                          const std::optional<PictureView>& view) {
  const double fits = ls::ResolutionThatFits(nodes, resolution, kPictureCells);
  absl::StatusOr<ls::OccupancyGrid> grid = ls::RenderOccupancy(nodes, fits, kPictureCells);
  if (!grid.ok()) return grid.status();
  const v1::OccupancyGrid proto = service::ToProtoGrid(*grid);
  cli::ScenePolyline robot_path;
  robot_path.color = {30, 150, 60};
  robot_path.points = trajectory;
  robot_path.mark_ends = true;
  absl::StatusOr<cv::Mat> picture = cli::OccupancyPicture(proto, {robot_path});
  if (!picture.ok()) return picture.status();
  // Every area and cell: the eval's picture is for looking at the whole map.
  cli::DrawMapSelfCheck(proto,
                        service::ToProtoMapSelfCheck(check.report, check.report.tiles.size(),
                                                     check.report.contradicting_cells.size()),
                        {}, &*picture);
  const double pixels_per_metre = cli::OccupancyPictureScale(proto, {}) / grid->resolution;
  const auto to_pixel = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround((x - grid->origin.x()) * pixels_per_metre)),
                     static_cast<int>(std::lround(picture->rows - (y - grid->origin.y()) *
                                                                       pixels_per_metre)));
  };
  if (view) {
    const cv::Rect area =
        cv::Rect(to_pixel(view->min.x, view->max.y), to_pixel(view->max.x, view->min.y)) &
        cv::Rect(0, 0, picture->cols, picture->rows);
    if (area.empty()) return absl::InvalidArgumentError("the view is outside the map");
    const double enlarge = std::max(1.0, 800.0 / std::max(area.width, area.height));
    cv::Mat cut;
    cv::resize((*picture)(area), cut, cv::Size(), enlarge, enlarge, cv::INTER_NEAREST);
    return cli::WritePngImage(cut, path);
  }
  return cli::WritePngImage(*picture, path);
}

absl::Status WriteSmallCheckedPicture(const std::filesystem::path& path,
                                      const std::vector<ls::NodeView>& nodes,
                                      const MapCheck& check, int size_px) {
  if (size_px < 16) return absl::InvalidArgumentError("a small picture is at least 16 pixels");
  // The map's extent (nodes and their points), so that its longer side is size_px cells.
  double min_x = 1e300, min_y = 1e300, max_x = -1e300, max_y = -1e300;
  for (const ls::NodeView& node : nodes) {
    const auto extend = [&](double x, double y) {
      min_x = std::min(min_x, x), max_x = std::max(max_x, x);
      min_y = std::min(min_y, y), max_y = std::max(max_y, y);
    };
    extend(node.global.x, node.global.y);
    if (node.points == nullptr) continue;
    const double c = std::cos(node.global.theta), s = std::sin(node.global.theta);
    for (const Eigen::Vector2f& q : *node.points) {
      extend(node.global.x + c * q.x() - s * q.y(), node.global.y + s * q.x() + c * q.y());
    }
  }
  if (min_x > max_x) return absl::FailedPreconditionError("no nodes to draw");
  const double span = std::max(max_x - min_x, max_y - min_y);
  const double resolution = std::max(0.05, std::ceil(span / (size_px - 2) * 1000.0) / 1000.0);
  absl::StatusOr<ls::OccupancyGrid> grid = ls::RenderOccupancy(nodes, resolution, kPictureCells);
  if (!grid.ok()) return grid.status();
  const v1::OccupancyGrid proto = service::ToProtoGrid(*grid);
  // No trajectory: the walls are what the eye judges here, and a path hides them at this size.
  const cli::OccupancyPictureOptions one_pixel_a_cell{.min_size_px = 0};
  absl::StatusOr<cv::Mat> picture = cli::OccupancyPicture(proto, {}, one_pixel_a_cell);
  if (!picture.ok()) return picture.status();
  cli::DrawMapSelfCheck(proto,
                        service::ToProtoMapSelfCheck(check.report, check.report.tiles.size(),
                                                     check.report.contradicting_cells.size()),
                        one_pixel_a_cell, &*picture);
  return cli::WriteSmallPalettePicture(*picture, size_px, path);
}

}  // namespace waymark::bench
