#include "server/service/slam/slam_params.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/service/slam/exploration_params.h"

namespace waymark::service {
namespace {

namespace ls = laser_slam;

// Field paths are given from CreateSessionRequest, as a client writes them.
constexpr char kParams[] = "laser.params.";

bool GeometryIsSet(const v1::LaserGeometry& g) {
  return g.beam_count() != 0 || g.angle_min() != 0.0 || g.angle_increment() != 0.0 ||
         g.no_return_range() != 0.0;
}

absl::Status ValidateGeometry(const ls::ScanGeometry& geometry, const std::string& field) {
  absl::Status status = ls::ValidateScanGeometry(geometry);
  if (status.ok()) return status;
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", status.message()));
}

absl::Status ValidateParams(const v1::LaserSlamParams& p, double min_range) {
  const std::string f = kParams;
  if (p.has_max_range()) {
    absl::Status s = InRange(p.max_range(), f + "max_range", min_range, 100.0, true, "m");
    if (!s.ok()) return s;
  }
  struct Check {
    bool set;
    double value;
    const char* name;
    double lo, hi;
    bool lo_open;
    const char* unit;
  };
  const Check checks[] = {
      {p.has_range_sigma(), p.range_sigma(), "range_sigma", 0.0, 1.0, true, "m"},
      {p.has_odom_xy_per_m(), p.odom_xy_per_m(), "odom_xy_per_m", 0.0, 10.0, false, "m per m"},
      {p.has_odom_theta_per_rad(), p.odom_theta_per_rad(), "odom_theta_per_rad", 0.0, 10.0, false,
       "rad per rad"},
      {p.has_odom_theta_per_m(), p.odom_theta_per_m(), "odom_theta_per_m", 0.0, 10.0, false,
       "rad per m"},
      {p.has_match_chi2(), p.match_chi2(), "match_chi2", 0.0, 1000.0, true, "(chi-square, 2 dof)"},
      {p.has_min_travel(), p.min_travel(), "min_travel", 0.0, 100.0, false, "m"},
      {p.has_min_turn(), p.min_turn(), "min_turn", 0.0, M_PI, false, "rad"},
  };
  for (const Check& c : checks) {
    if (!c.set) continue;
    absl::Status s = InRange(c.value, f + c.name, c.lo, c.hi, c.lo_open, c.unit);
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

// A pose named `field` with |x|, |y| <= `extent` metres and theta in [-2 pi, 2 pi].
absl::Status ValidatePose(const v1::Pose2D& pose, const std::string& field, double extent) {
  for (const auto& [value, name] : {std::pair<double, const char*>{pose.x(), "x"},
                                    {pose.y(), "y"}}) {
    absl::Status s = InRange(value, absl::StrCat(field, ".", name), -extent, extent, false, "m");
    if (!s.ok()) return s;
  }
  return InRange(pose.theta(), field + ".theta", -2 * M_PI, 2 * M_PI, false, "rad");
}

absl::Status ValidateLaserPose(const v1::Pose2D& pose) {
  return ValidatePose(pose, "laser.laser_pose", 100.0);
}

}  // namespace

absl::Status InRange(double value, const std::string& field, double lo, double hi, bool lo_open,
                     const char* unit) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (ok) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, " must be in ", lo_open ? "(" : "[", lo,
                                                 ", ", hi, "] ", unit, ", got ", value));
}

ls::ScanGeometry ToScanGeometry(const v1::LaserGeometry& geometry) {
  ls::ScanGeometry g;
  g.angle_min = geometry.angle_min();
  g.angle_increment = geometry.angle_increment();
  // Clamp before narrowing: a uint32 above INT_MAX must not turn into a valid-looking count.
  g.beam_count = geometry.beam_count() > 1000000000u ? 1000000000
                                                     : static_cast<int>(geometry.beam_count());
  g.no_return_range = geometry.no_return_range();
  return g;
}

v1::LaserGeometry ToProtoGeometry(const ls::ScanGeometry& geometry) {
  v1::LaserGeometry g;
  g.set_angle_min(geometry.angle_min);
  g.set_angle_increment(geometry.angle_increment);
  g.set_beam_count(static_cast<uint32_t>(geometry.beam_count < 0 ? 0 : geometry.beam_count));
  g.set_no_return_range(geometry.no_return_range);
  return g;
}

absl::StatusOr<LaserSessionOptions> ToLaserSessionOptions(const v1::LaserSlamConfig& config) {
  LaserSessionOptions options;
  if (GeometryIsSet(config.laser())) {
    options.geometry = ToScanGeometry(config.laser());
    absl::Status s = ValidateGeometry(options.geometry, "laser.laser (session geometry)");
    if (!s.ok()) return s;
  }
  if (absl::Status s = ValidateLaserPose(config.laser_pose()); !s.ok()) return s;
  options.slam.laser_pose = FromProtoPose(config.laser_pose());
  const v1::LaserSlamParams& p = config.params();
  if (absl::Status s = ValidateParams(p, options.slam.extraction.min_range); !s.ok()) return s;
  if (p.has_max_range()) options.slam.extraction.max_range = p.max_range();
  if (p.has_range_sigma()) options.slam.extraction.range_sigma = p.range_sigma();
  if (p.has_odom_xy_per_m()) options.slam.odometry.xy_per_m = p.odom_xy_per_m();
  if (p.has_odom_theta_per_rad()) options.slam.odometry.theta_per_rad = p.odom_theta_per_rad();
  if (p.has_odom_theta_per_m()) options.slam.odometry.theta_per_m = p.odom_theta_per_m();
  if (p.has_match_chi2()) options.slam.ekf.match_chi2 = p.match_chi2();
  if (p.has_min_travel()) options.slam.ekf.min_travel = p.min_travel();
  if (p.has_min_turn()) options.slam.ekf.min_turn = p.min_turn();
  if (absl::Status s = ApplyExplorationConfig(config.exploration(), &options.slam.exploration);
      !s.ok()) {
    return s;
  }
  if (p.has_loop_closure()) options.slam.mapping.enabled = p.loop_closure();
  if (p.has_prune_redundant_submaps()) {
    options.slam.mapping.prune_redundant_submaps = p.prune_redundant_submaps();
  }
  // The server never lets a search or an optimisation hold up a robot's stream.
  options.slam.mapping.threads = 1;
  if (config.has_localize()) {
    const v1::LocalizationConfig& l = config.localize();
    if (l.map_session_id().empty() || l.map_session_id().size() > 128) {
      return absl::InvalidArgumentError(
          "localize.map_session_id must name the closed laser session to localize on");
    }
    ls::LocalizationOptions lo;
    if (l.has_initial_pose()) {
      if (absl::Status s = ValidatePose(l.initial_pose(), "localize.initial_pose", 1e6); !s.ok()) return s;
      lo.initial_pose = FromProtoPose(l.initial_pose());
    }
    if (l.has_initial_sigma_xy()) {
      if (absl::Status s = InRange(l.initial_sigma_xy(), "localize.initial_sigma_xy", 0, 100, true, "m");
          !s.ok()) {
        return s;
      }
      lo.initial_sigma_xy = l.initial_sigma_xy();
    }
    if (l.has_initial_sigma_theta()) {
      if (absl::Status s = InRange(l.initial_sigma_theta(), "localize.initial_sigma_theta", 0, M_PI,
                                   true, "rad");
          !s.ok()) {
        return s;
      }
      lo.initial_sigma_theta = l.initial_sigma_theta();
    }
    lo.point_range = options.slam.mapping.point_range;
    // As the back end's: the global search runs on the localizer's thread, not the stream's.
    lo.threads = 1;
    if (absl::Status s = ls::ValidateLocalizationOptions(lo); !s.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("localize: ", s.message()));
    }
    options.map_session_id = l.map_session_id();
    options.localize = lo;
  }
  // The engine's own check covers combinations (and anything added to it later).
  if (absl::Status s = ls::ValidateSlamOptions(options.slam); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("laser.params: ", s.message()));
  }
  return options;
}

absl::StatusOr<v1::LaserSlamConfig> EffectiveLaserConfig(const v1::LaserSlamConfig& config) {
  absl::StatusOr<LaserSessionOptions> options = ToLaserSessionOptions(config);
  if (!options.ok()) return options.status();
  v1::LaserSlamConfig effective = config;
  v1::LaserSlamParams* p = effective.mutable_params();
  const ls::SlamOptions& o = options->slam;
  p->set_max_range(o.extraction.max_range);
  p->set_range_sigma(o.extraction.range_sigma);
  p->set_odom_xy_per_m(o.odometry.xy_per_m);
  p->set_odom_theta_per_rad(o.odometry.theta_per_rad);
  p->set_odom_theta_per_m(o.odometry.theta_per_m);
  p->set_match_chi2(o.ekf.match_chi2);
  p->set_min_travel(o.ekf.min_travel);
  p->set_min_turn(o.ekf.min_turn);
  p->set_loop_closure(o.mapping.enabled);
  p->set_prune_redundant_submaps(o.mapping.prune_redundant_submaps);
  if (options->localize) {
    v1::LocalizationConfig* l = effective.mutable_localize();
    l->set_initial_sigma_xy(options->localize->initial_sigma_xy);
    l->set_initial_sigma_theta(options->localize->initial_sigma_theta);
  }
  FillEffectiveExploration(o.exploration, effective.mutable_exploration());
  return effective;
}

absl::StatusOr<ls::OdometryReading> ToOdometryReading(const v1::Odometry& odometry) {
  if (!std::isfinite(odometry.stamp())) {
    return absl::InvalidArgumentError(
        absl::StrCat("odometry.stamp must be a finite number of seconds, got ", odometry.stamp()));
  }
  const v1::Pose2D& p = odometry.pose();
  if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.theta())) {
    return absl::InvalidArgumentError(absl::StrCat("odometry.pose must be finite, got (", p.x(),
                                                   ", ", p.y(), ", ", p.theta(), ")"));
  }
  ls::OdometryReading reading;
  reading.stamp = odometry.stamp();
  reading.pose = FromProtoPose(p);
  return reading;
}

absl::StatusOr<ls::LaserScan> ToLaserScan(const v1::LaserScan& scan,
                                          const ls::ScanGeometry& session_geometry) {
  if (!std::isfinite(scan.stamp())) {
    return absl::InvalidArgumentError(
        absl::StrCat("scan.stamp must be a finite number of seconds, got ", scan.stamp()));
  }
  if (scan.ranges_size() > kMaxScanBeams) {
    return absl::InvalidArgumentError(absl::StrCat("scan has ", scan.ranges_size(),
                                                   " ranges; at most ", kMaxScanBeams,
                                                   " beams per scan are accepted"));
  }
  ls::LaserScan out;
  out.stamp = scan.stamp();
  if (scan.has_geometry()) {
    out.geometry = ToScanGeometry(scan.geometry());
    if (absl::Status s = ValidateGeometry(out.geometry, "scan.geometry"); !s.ok()) return s;
    if (scan.ranges_size() != out.geometry.beam_count) {
      return absl::InvalidArgumentError(
          absl::StrCat("scan has ", scan.ranges_size(), " ranges but scan.geometry.beam_count is ",
                       out.geometry.beam_count, "; send one range per beam"));
    }
  } else {
    if (session_geometry.beam_count == 0) {
      return absl::InvalidArgumentError(
          "scan has no geometry and the session was created without laser geometry: set "
          "scan.geometry (angle_min, angle_increment, beam_count) or create the session with "
          "laser.laser");
    }
    out.geometry = session_geometry;
    if (scan.ranges_size() != out.geometry.beam_count) {
      return absl::InvalidArgumentError(absl::StrCat(
          "scan has ", scan.ranges_size(), " ranges but the session's laser geometry has beam_count ",
          out.geometry.beam_count, "; send one range per beam, or set scan.geometry when the beam "
          "layout differs"));
    }
  }
  out.ranges.assign(scan.ranges().begin(), scan.ranges().end());
  return out;
}

v1::Pose2D ToProtoPose(const ls::Pose2& pose) {
  v1::Pose2D p;
  p.set_x(pose.x);
  p.set_y(pose.y);
  p.set_theta(pose.theta);
  return p;
}

ls::Pose2 FromProtoPose(const v1::Pose2D& pose) { return ls::Pose2{pose.x(), pose.y(), pose.theta()}; }

v1::TrajectoryPose ToProtoTrajectoryPose(const ls::PoseEstimate& pose) {
  v1::TrajectoryPose p;
  p.set_stamp(pose.stamp);
  *p.mutable_pose() = ToProtoPose(pose.pose);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) p.add_covariance(pose.covariance(r, c));
  }
  return p;
}

v1::MapSegment ToProtoSegment(const ls::MapSegment& segment) {
  v1::MapSegment s;
  s.set_id(segment.id);
  *s.mutable_frame() = ToProtoPose(segment.frame);
  s.set_left(segment.left);
  s.set_right(segment.right);
  s.set_left_type(segment.left_type == ls::EndpointType::kReal ? v1::MapSegment::REAL
                                                                : v1::MapSegment::VIRTUAL);
  s.set_right_type(segment.right_type == ls::EndpointType::kReal ? v1::MapSegment::REAL
                                                                  : v1::MapSegment::VIRTUAL);
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) s.add_line_covariance(segment.line_covariance(r, c));
  }
  s.set_left_variance(segment.left_variance);
  s.set_right_variance(segment.right_variance);
  s.set_observations(static_cast<uint32_t>(segment.observations < 0 ? 0 : segment.observations));
  s.set_active(segment.active);
  s.set_last_seen_scan(segment.last_seen_scan);
  return s;
}

ls::MapSegment FromProtoSegment(const v1::MapSegment& s) {
  ls::MapSegment segment;
  segment.id = s.id();
  segment.frame = FromProtoPose(s.frame());
  segment.left = s.left();
  segment.right = s.right();
  segment.left_type = s.left_type() == v1::MapSegment::REAL ? ls::EndpointType::kReal
                                                            : ls::EndpointType::kVirtual;
  segment.right_type = s.right_type() == v1::MapSegment::REAL ? ls::EndpointType::kReal
                                                              : ls::EndpointType::kVirtual;
  if (s.line_covariance_size() == 4) {
    segment.line_covariance << s.line_covariance(0), s.line_covariance(1), s.line_covariance(2),
        s.line_covariance(3);
  }
  segment.left_variance = s.left_variance();
  segment.right_variance = s.right_variance();
  segment.observations = static_cast<int>(s.observations());
  segment.last_seen_scan = s.last_seen_scan();
  segment.active = s.active();
  return segment;
}

namespace {

v1::LocalizationStatus::State ToProtoLocalizationState(ls::LocalizationState state) {
  switch (state) {
    case ls::LocalizationState::kTracking: return v1::LocalizationStatus::TRACKING;
    case ls::LocalizationState::kFromStart: return v1::LocalizationStatus::FROM_START;
    case ls::LocalizationState::kSearching: return v1::LocalizationStatus::SEARCHING;
    case ls::LocalizationState::kConfirming: return v1::LocalizationStatus::CONFIRMING;
    case ls::LocalizationState::kAmbiguous: return v1::LocalizationStatus::AMBIGUOUS;
  }
  return v1::LocalizationStatus::STATE_UNSPECIFIED;
}

}  // namespace

void FillSlamUpdate(const ls::ScanUpdate& scan_update, v1::SlamUpdate* update) {
  update->set_stamp(scan_update.pose.stamp);
  *update->mutable_pose() = ToProtoPose(scan_update.pose.pose);
  update->clear_covariance();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) update->add_covariance(scan_update.pose.covariance(r, c));
  }
  auto count = [](int n) { return static_cast<uint32_t>(n < 0 ? 0 : n); };
  update->set_segments(count(scan_update.segments));
  update->set_map_revision(scan_update.map_revision);
  update->set_observed_segments(count(scan_update.observed));
  update->set_matched_segments(count(scan_update.matched));
  update->set_added_segments(count(scan_update.added));
  update->set_skipped(scan_update.skipped);
  update->set_odometry_reset(scan_update.odometry_reset);
  v1::SlamTimings* t = update->mutable_timings();
  t->set_extraction_ms(scan_update.timings.extraction);
  t->set_prediction_ms(scan_update.timings.prediction);
  t->set_association_ms(scan_update.timings.association);
  t->set_update_ms(scan_update.timings.update);
  t->set_total_ms(scan_update.timings.total);
  update->set_covariance_trace_mean(scan_update.covariance_trace_mean);
  if (scan_update.suggestion) FillSuggestion(*scan_update.suggestion, update->mutable_suggestion());
  if (scan_update.exploration) {
    FillExplorationProgress(*scan_update.exploration, update->mutable_exploration());
  }
  update->set_loop_closures(count(scan_update.loop_closures));
  update->set_graph_revision(scan_update.graph_revision);
  if (scan_update.localization) {
    const ls::LocalizationResult& l = *scan_update.localization;
    v1::LocalizationStatus* out = update->mutable_localization();
    out->set_localized(l.localized);
    out->set_score(l.score);
    out->set_fixes(count(l.fixes));
    out->set_last_fix_stamp(l.last_fix_stamp);
    out->set_global_search(l.global_search);
    out->set_state(ToProtoLocalizationState(l.state));
    out->set_rival_ratio(l.rival_ratio);
    out->set_rival_distance(l.rival_distance);
    out->set_rival_angle(l.rival_angle);
  }
}

v1::OccupancyGrid ToProtoGrid(const ls::OccupancyGrid& grid) {
  v1::OccupancyGrid out;
  out.set_resolution(grid.resolution);
  out.mutable_origin()->set_x(grid.origin.x());
  out.mutable_origin()->set_y(grid.origin.y());
  out.set_width(static_cast<uint32_t>(grid.width));
  out.set_height(static_cast<uint32_t>(grid.height));
  out.set_cells(std::string(reinterpret_cast<const char*>(grid.cells.data()), grid.cells.size()));
  return out;
}

absl::StatusOr<ls::OccupancyGrid> FromProtoGrid(const v1::OccupancyGrid& in) {
  if (absl::Status s = InRange(in.resolution(), "grid.resolution", 0.005, 10.0, false, "m");
      !s.ok()) {
    return s;
  }
  if (!std::isfinite(in.origin().x()) || !std::isfinite(in.origin().y()) ||
      std::abs(in.origin().x()) > 1e7 || std::abs(in.origin().y()) > 1e7) {
    return absl::InvalidArgumentError("grid.origin must be finite and within 10000 km");
  }
  if (in.width() == 0 || in.height() == 0) {
    return absl::InvalidArgumentError("grid.width and grid.height must be positive");
  }
  const uint64_t cells = static_cast<uint64_t>(in.width()) * in.height();
  if (cells > static_cast<uint64_t>(ls::kMaxOccupancyCells)) {
    return absl::InvalidArgumentError(absl::StrCat("grid has ", cells, " cells; at most ",
                                                   ls::kMaxOccupancyCells));
  }
  if (in.cells().size() != cells) {
    return absl::InvalidArgumentError(absl::StrCat("grid.cells has ", in.cells().size(),
                                                   " bytes; width x height is ", cells));
  }
  ls::OccupancyGrid grid;
  grid.resolution = in.resolution();
  grid.origin = Eigen::Vector2d(in.origin().x(), in.origin().y());
  grid.width = static_cast<int>(in.width());
  grid.height = static_cast<int>(in.height());
  grid.cells.resize(cells);
  int occupied = 0;
  for (size_t k = 0; k < cells; ++k) {
    const auto v = static_cast<std::int8_t>(in.cells()[k]);
    if (v < -1 || v > 100) {
      return absl::InvalidArgumentError(absl::StrCat(
          "grid.cells[", k, "] is ", int(v), "; cells are -1 (unknown) or 0..100"));
    }
    grid.cells[k] = v;
    occupied += v >= 65 ? 1 : 0;
  }
  if (occupied == 0) {
    return absl::InvalidArgumentError(
        "grid has no occupied cell (>= 65): there is nothing to localize against");
  }
  return grid;
}

}  // namespace waymark::service
