#include "server/laser_slam/laser_slam.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/binary_io.h"
#include "server/common/stopwatch.h"
#include "server/laser_slam/exploration/exploration_planner.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/input_bounds.h"
#include "server/laser_slam/line_extraction.h"
#include "server/laser_slam/mapping/graph_codec.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/motion.h"
#include "server/laser_slam/odometry_buffer.h"
#include "server/laser_slam/segment_ekf.h"

namespace waymark::laser_slam {
namespace {

constexpr std::uint32_t kMagic = 0x534c4d57;  // "WMLS"
// 1: the EKF alone; 2: followed by what the session has beside the EKF (a kind byte, a length and
// its bytes).
constexpr std::uint32_t kVersion = 2;
enum class Beside : std::uint8_t { kNothing = 0, kGraph = 1, kLocalizer = 2, kImportedGrid = 3 };

void PutGrid(BinaryWriter& w, const OccupancyGrid& g) {
  w.Put(g.resolution);
  w.Put(g.origin.x());
  w.Put(g.origin.y());
  w.Put<std::int32_t>(g.width);
  w.Put<std::int32_t>(g.height);
  for (std::int8_t c : g.cells) w.Put(c);
}

bool GetGrid(BinaryReader& r, OccupancyGrid* g) {
  double ox = 0, oy = 0;
  std::int32_t width = 0, height = 0;
  if (!r.Get(&g->resolution) || !r.Get(&ox) || !r.Get(&oy) || !r.Get(&width) || !r.Get(&height) ||
      !(g->resolution > 0) || width < 0 || height < 0 ||
      static_cast<std::int64_t>(width) * height > kMaxOccupancyCells ||
      r.remaining() < static_cast<size_t>(width) * height) {
    return false;
  }
  g->origin = Eigen::Vector2d(ox, oy);
  g->width = width;
  g->height = height;
  g->cells.resize(static_cast<size_t>(width) * height);
  for (std::int8_t& c : g->cells) r.Get(&c);
  return true;
}

}  // namespace

struct LaserSlam::Impl {
  Impl(const SlamOptions& o, std::unique_ptr<MapLocalizer> l)
      : options(o), ekf(o.ekf), before_scan(o.ekf), localizer(std::move(l)) {
    if (o.exploration.mode != ExplorationMode::kPassive) {
      planner = std::make_unique<ExplorationPlanner>(o.exploration);
    }
    if (o.mapping.enabled && !localizer) backend = std::make_unique<MappingBackend>(o.mapping);
  }

  SlamOptions options;
  SegmentEkf ekf;
  SegmentEkf before_scan;  // the filter before the scan being processed (AddScan's rollback)
  std::unique_ptr<ExplorationPlanner> planner;  // active and wander sessions
  std::unique_ptr<MappingBackend> backend;      // loop closure (options.mapping.enabled)
  std::unique_ptr<MapConsistencyChecker> map_checker;  // CheckMap's cache, made on its first call
  std::unique_ptr<MapLocalizer> localizer;      // localization sessions
  std::optional<OccupancyGrid> imported_grid;   // an imported map's session
  LaserScan last_scan;                          // what the planner avoids
  OdometryBuffer odometry;
  bool have_scan = false;
  double last_scan_stamp = 0.0;
  Pose2 odometry_at_last_update;  // odometry pose when the filter last moved the robot
  std::vector<PoseEstimate> trajectory;
  std::uint64_t revision = 0;
  std::uint64_t scans = 0;
  std::vector<Teammate> teammates;  // in the session's frame (SetTeammates)
  Pose2 local_to_session;  // the back end's correction at the last scan

  PoseEstimate Current(double stamp) const {
    PoseEstimate p;
    p.stamp = stamp;
    p.pose = ekf.state().robot;
    p.covariance = ekf.state().cov().topLeftCorner<3, 3>();
    return p;
  }

  // A local pose of scan `scan` (1-based) in the map frame.
  PoseEstimate ToMap(std::uint64_t scan, PoseEstimate p) const {
    if (backend) p.pose = backend->ToGlobal(scan, p.pose);
    if (localizer) p.pose = localizer->ToMap(scan, p.pose);
    return p;
  }
};

LaserSlam::LaserSlam(const SlamOptions& options, std::unique_ptr<MapLocalizer> localizer)
    : impl_(std::make_unique<Impl>(options, std::move(localizer))) {}

std::unique_ptr<LaserSlam> LaserSlam::FromImportedGrid(const SlamOptions& options,
                                                       OccupancyGrid grid) {
  SlamOptions plain = options;
  plain.mapping.enabled = false;
  auto slam = std::make_unique<LaserSlam>(plain);
  slam->impl_->imported_grid = std::move(grid);
  return slam;
}
LaserSlam::~LaserSlam() = default;

absl::Status LaserSlam::AddOdometry(const OdometryReading& reading) {
  return impl_->odometry.Add(reading);
}

absl::StatusOr<ScanUpdate> LaserSlam::AddScan(const LaserScan& scan) {
  Impl& s = *impl_;
  const auto start = Clock::now();
  if (!std::isfinite(scan.stamp)) return absl::InvalidArgumentError("scan stamp must be finite");
  if (!PlausibleStamp(scan.stamp)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "scan stamp ", scan.stamp, " s is not a time (|stamp| <= ", kMaxAbsStampS, ")"));
  }
  if (s.have_scan && scan.stamp <= s.last_scan_stamp) {
    return absl::InvalidArgumentError(
        absl::StrCat("scan stamp ", scan.stamp, " is not after the previous scan's (",
                     s.last_scan_stamp, "): scans must arrive in time order"));
  }
  ScanUpdate update;
  absl::StatusOr<std::vector<ObservedSegment>> observed =
      ExtractSegments(scan, s.options.extraction);
  if (!observed.ok()) return observed.status();
  update.timings.extraction = MsSince(start);
  // What this scan changes outside the filter, to put back if it is refused below.
  LaserScan previous_scan = std::exchange(s.last_scan, scan);
  const bool had_scan = s.have_scan;
  const double previous_stamp = s.last_scan_stamp;

  // Motion since the last update, from odometry interpolated at the scan stamp.
  const auto predict_start = Clock::now();
  const Pose2 odom = s.odometry.At(scan.stamp).value_or(s.odometry_at_last_update);
  Pose2 u = s.have_scan ? Relative(s.odometry_at_last_update, odom) : Pose2{};
  if (std::hypot(u.x, u.y) > kMaxOdometryStepM) {
    update.odometry_reset = true;
    u = Pose2{};
  }
  const bool too_little_motion = s.have_scan && std::hypot(u.x, u.y) < s.options.ekf.min_travel &&
                                 std::abs(u.theta) < s.options.ekf.min_turn;
  s.have_scan = true;
  s.last_scan_stamp = scan.stamp;
  ++s.scans;
  if (too_little_motion) {
    // Report where odometry puts the robot without touching the filter.
    update.skipped = true;
    update.pose = s.Current(scan.stamp);
    update.pose.pose = Compose(update.pose.pose, u);
  } else {
    // The filter as it was, to go back to if this scan would leave it non-finite (bounded
    // inputs should never; an answer with NaN or inf must not leave the server either way).
    s.ekf.CopyForRollback(&s.before_scan);  // into buffers kept between scans: no allocation
    const Pose2 odometry_before = s.odometry_at_last_update;
    if (s.scans > 1) s.ekf.Predict(u, IncrementNoise(u, s.options.odometry));
    s.odometry_at_last_update = odom;
    update.timings.prediction = MsSince(predict_start);
    const ObserveStats stats = s.ekf.Observe(*observed, s.options.laser_pose, s.scans);
    update.timings.association = stats.association_ms;
    update.timings.update = stats.update_ms;
    update.matched = stats.matched;
    update.added = stats.added;
    bool changed = stats.map_changed;
    if (s.options.ekf.merge_every_scans > 0 && s.scans % s.options.ekf.merge_every_scans == 0) {
      const auto merge_start = Clock::now();
      update.merged = s.ekf.MergeSegments(s.scans);
      update.timings.update += MsSince(merge_start);
      changed = changed || update.merged > 0;
    }
    update.pose = s.Current(scan.stamp);
    if (!FinitePose(update.pose.pose) || !update.pose.covariance.allFinite() ||
        !s.ekf.state().cov().diagonal().allFinite()) {
      s.ekf.RestoreFrom(s.before_scan);
      s.odometry_at_last_update = odometry_before;
      s.last_scan = std::move(previous_scan);
      s.have_scan = had_scan;
      s.last_scan_stamp = previous_stamp;
      --s.scans;
      return absl::InvalidArgumentError(
          "the scan would leave the filter with non-finite values; it was not applied and the "
          "session keeps its previous state");
    }
    if (changed) ++s.revision;
    if (s.backend || s.localizer) {
      const PointCloud points =
          ScanToPoints(scan, s.options.laser_pose, s.options.extraction.min_range,
                       s.options.mapping.point_range);
      if (s.backend) {
        s.backend->AddScan(s.scans, scan.stamp, update.pose.pose, points,
                           ScanMotion{u, IncrementNoise(u, s.options.odometry)});
      }
      if (s.localizer) {
        update.localization = s.localizer->AddScan(s.scans, scan.stamp, update.pose.pose, points);
      }
    }
  }
  s.odometry.DropBefore(scan.stamp);
  update.observed = static_cast<int>(observed->size());
  update.active_segments = static_cast<int>(s.ekf.state().segments.size());
  update.segments = update.active_segments + static_cast<int>(s.ekf.state().frozen.size());
  update.state_size = s.ekf.state().size();
  update.map_revision = map_revision();
  update.covariance_trace_mean = s.ekf.state().cov().trace() / s.ekf.state().size();
  s.trajectory.push_back(update.pose);
  update.pose = s.ToMap(s.scans, update.pose);
  if (s.localizer && !update.localization) update.localization = s.localizer->last();
  if (s.backend) {
    update.loop_closures = s.backend->loop_closures();
    update.graph_revision = s.backend->revision();
  }
  update.timings.total = MsSince(start);
  // Planning is timed on its own (Suggestion::planning_ms), not as part of the filter's total.
  if (s.planner) {
    // The goal layer works in the planner's (local) frame; answers are in the map frame.
    const Pose2 to_map = Compose(update.pose.pose, Invert(s.trajectory.back().pose));
    s.local_to_session = to_map;
    ExplorationView view = View();
    if (!s.teammates.empty()) {
      const Pose2 from_session = Invert(to_map);
      view.teammates = s.teammates;
      for (Teammate& t : view.teammates) t.to_here = Compose(from_session, t.to_here);
    }
    update.suggestion = s.planner->Decide(view);
    if (const ExplorationGoals* goals = s.planner->goals()) {
      auto move = [&](Eigen::Vector2d& p) { p = MoveBy(to_map, p); };
      GoalProgress progress = goals->progress();
      if (progress.target) {
        move(progress.target->goal);
        move(progress.target->look_at);
      }
      for (Eigen::Vector2d& p : progress.path) move(p);
      update.exploration = std::move(progress);
    }
  }
  return update;
}

void LaserSlam::SetTeammates(std::vector<Teammate> teammates) {
  impl_->teammates = std::move(teammates);
}

std::shared_ptr<const ExplorationSnapshot> LaserSlam::TeamSnapshot() const {
  const Impl& s = *impl_;
  const ExplorationGoals* goals = s.planner ? s.planner->goals() : nullptr;
  if (goals == nullptr || s.trajectory.empty()) return nullptr;
  auto snapshot = std::make_shared<ExplorationSnapshot>();
  snapshot->grid = goals->own_grid();
  snapshot->segments = LocalMap();
  snapshot->robot = s.trajectory.back().pose;
  snapshot->stood = goals->stood();
  snapshot->looked_at_open = goals->looked_at_open();
  const GoalProgress& progress = goals->progress();
  if (progress.target) snapshot->claim = progress.target->look_at;
  snapshot->finished = progress.state != ExplorationState::kExploring;
  snapshot->local_to_session = s.local_to_session;
  return snapshot;
}

PoseEstimate LaserSlam::CurrentPose() const {
  const Impl& s = *impl_;
  return s.trajectory.empty() ? s.Current(0.0) : s.ToMap(s.scans, s.trajectory.back());
}

ExplorationView LaserSlam::View() const {
  const Impl& s = *impl_;
  const SpState& st = s.ekf.state();
  ExplorationView view;
  view.robot = st.robot;
  view.robot_covariance = st.cov().topLeftCorner<3, 3>();
  for (const SegmentEntity& e : st.segments) {
    const std::vector<int> dofs = SegmentDofs(e);
    Eigen::MatrixXd block(dofs.size(), dofs.size());
    for (size_t i = 0; i < dofs.size(); ++i) {
      for (size_t j = 0; j < dofs.size(); ++j) block(i, j) = st.at(dofs[i], dofs[j]);
    }
    view.map_uncertainty += M_PI * std::sqrt(std::max(block.determinant(), 0.0));
  }
  view.segments = LocalMap();
  view.scan = s.last_scan;
  view.laser_pose = s.options.laser_pose;
  view.max_range = s.options.extraction.max_range;
  view.min_incidence = s.options.extraction.min_incidence;
  view.odometry = s.options.odometry;
  view.loop_closures = s.backend ? s.backend->loop_closures() : -1;
  return view;
}

namespace {

// The fields a map segment takes from its entity, active or frozen alike.
MapSegment FromEntity(const SegmentEntity& e, bool active) {
  MapSegment m;
  m.id = e.id;
  m.frame = e.frame;
  m.left = e.left;
  m.right = e.right;
  m.left_type = e.left_type;
  m.right_type = e.right_type;
  m.observations = e.observations;
  m.last_seen_scan = e.last_seen_scan;
  m.active = active;
  return m;
}

}  // namespace

std::vector<MapSegment> LaserSlam::Map() const {
  std::vector<MapSegment> out = LocalMap();
  if (impl_->backend) {
    impl_->backend->WaitForPending();  // local matching moves a node when the thread gets to it
    // Each segment by the correction at the scan that last matched it, where the robot was then
    // (the correction between two nodes depends on how far along the robot is).
    const std::vector<PoseEstimate>& robot = impl_->trajectory;
    for (MapSegment& m : out) {
      const std::uint64_t k = m.last_seen_scan;
      const Pose2 at = k >= 1 && k <= robot.size() ? robot[k - 1].pose : Pose2{};
      m.frame = Compose(impl_->backend->CorrectionAt(k, at), m.frame);
    }
  }
  return out;
}

std::vector<MapSegment> LaserSlam::LocalMap() const {
  const SpState& st = impl_->ekf.state();
  std::vector<MapSegment> out;
  out.reserve(st.segments.size() + st.frozen.size());
  for (const SegmentEntity& e : st.segments) {
    MapSegment m = FromEntity(e, true);
    m.line_covariance << st.at(e.dof[0], e.dof[0]), st.at(e.dof[0], e.dof[1]),
        st.at(e.dof[1], e.dof[0]), st.at(e.dof[1], e.dof[1]);
    m.left_variance = e.dof[2] >= 0 ? st.at(e.dof[2], e.dof[2]) : 0.0;
    m.right_variance = e.dof[3] >= 0 ? st.at(e.dof[3], e.dof[3]) : 0.0;
    out.push_back(m);
  }
  for (const FrozenSegment& f : st.frozen) {
    MapSegment m = FromEntity(f.entity, false);
    m.line_covariance = f.line_covariance;
    m.left_variance = f.left_variance;
    m.right_variance = f.right_variance;
    out.push_back(m);
  }
  return out;
}

std::vector<PoseEstimate> LaserSlam::Trajectory() const {
  const Impl& s = *impl_;
  if (!s.backend && !s.localizer) return s.trajectory;
  if (s.backend) s.backend->WaitForPending();  // as RenderGrid: every scan at its matched pose
  // Pose k is scan k + 1 of the session (every scan has one, skipped or not).
  std::vector<PoseEstimate> out = s.trajectory;
  for (size_t k = 0; k < out.size(); ++k) out[k] = s.ToMap(k + 1, out[k]);
  return out;
}

const std::vector<PoseEstimate>& LaserSlam::LocalTrajectory() const { return impl_->trajectory; }

void LaserSlam::FlushBackend() {
  if (impl_->backend) impl_->backend->Flush();
  // The final map is checked afresh: the cache re-casts only submaps that moved a quarter cell,
  // and a closed session's verdict must be the one its map gives when it is loaded again.
  impl_->map_checker.reset();
}

const MappingBackend* LaserSlam::backend() const { return impl_->backend.get(); }

namespace {

absl::Status NoScansKept() {
  return absl::FailedPreconditionError(
      "this session keeps no scans (loop closure is off: the paper's EKF alone, or a "
      "localization session): it has a segment map but no occupancy grid");
}

}  // namespace

absl::StatusOr<OccupancyGrid> LaserSlam::RenderGrid(double resolution,
                                                    std::int64_t max_cells) const {
  if (impl_->imported_grid) return *impl_->imported_grid;
  if (!impl_->backend) return NoScansKept();
  // Every scan sent so far at the pose local matching gives it (the thread may be behind).
  impl_->backend->WaitForPending();
  const std::vector<NodeView> nodes = impl_->backend->Nodes();
  return RenderOccupancy(nodes, ResolutionThatFits(nodes, resolution, max_cells), max_cells);
}

absl::StatusOr<PointCloud> LaserSlam::MapPoints() const {
  if (impl_->imported_grid) return OccupiedPoints(*impl_->imported_grid);
  if (!impl_->backend) return NoScansKept();
  impl_->backend->WaitForPending();
  PointCloud points;
  for (const NodeView& n : impl_->backend->Nodes()) AppendTransformed(*n.points, n.global, &points);
  return points;
}

absl::StatusOr<MapConsistencyReport> LaserSlam::CheckMap() {
  Impl& s = *impl_;
  if (!s.backend) return NoScansKept();
  if (!s.map_checker) {
    MapConsistencyOptions options;
    options.submap_nodes = s.options.mapping.submap_nodes;
    s.map_checker = std::make_unique<MapConsistencyChecker>(options);
  }
  s.backend->WaitForPending();
  return s.map_checker->Check(s.backend->Nodes());
}

std::uint64_t LaserSlam::map_revision() const {
  return impl_->revision + (impl_->backend ? impl_->backend->revision() : 0);
}
std::uint64_t LaserSlam::scans_processed() const { return impl_->scans; }
const SlamOptions& LaserSlam::options() const { return impl_->options; }

namespace {

// Every stored pose (the robot's, the trajectory's, a segment's frame) is read with GetPose
// (graph_codec.h), within the map's bounds (input_bounds.h): a robot pose of 1e300 m, read
// unchecked, reached the loop search as an infinite scan point (undefined behaviour; found by
// make fuzz).

void PutSegment(BinaryWriter& w, const SegmentEntity& e) {
  w.Put(e.id);
  PutPose(w, e.frame);
  w.Put(e.left);
  w.Put(e.right);
  w.Put<std::uint8_t>(static_cast<std::uint8_t>(e.left_type));
  w.Put<std::uint8_t>(static_cast<std::uint8_t>(e.right_type));
  for (int d : e.dof) w.Put<std::int32_t>(d);
  w.Put<std::int32_t>(e.observations);
  w.Put(e.first_seen_scan);
  w.Put(e.last_seen_scan);
}

bool GetSegment(BinaryReader& r, SegmentEntity* e) {
  std::uint8_t lt = 0, rt = 0;
  std::int32_t obs = 0;
  if (!r.Get(&e->id) || !GetPose(r, &e->frame) || !r.Get(&e->left) || !r.Get(&e->right) ||
      !(std::abs(e->left) <= kMaxAbsMapM) || !(std::abs(e->right) <= kMaxAbsMapM) ||
      !r.Get(&lt) || !r.Get(&rt) || lt > 1 || rt > 1) {
    return false;
  }
  e->left_type = static_cast<EndpointType>(lt);
  e->right_type = static_cast<EndpointType>(rt);
  for (int& d : e->dof) {
    std::int32_t v = 0;
    if (!r.Get(&v)) return false;
    d = v;
  }
  if (!r.Get(&obs) || !r.Get(&e->first_seen_scan) || !r.Get(&e->last_seen_scan)) return false;
  e->observations = obs;
  return true;
}

}  // namespace

std::string LaserSlam::SerializeState() const {
  const Impl& s = *impl_;
  const SpState& st = s.ekf.state();
  BinaryWriter w;
  w.Put(kMagic);
  w.Put(kVersion);
  w.Put<std::uint8_t>(s.have_scan);
  w.Put(s.last_scan_stamp);
  PutPose(w, s.odometry_at_last_update);
  w.Put(s.revision);
  w.Put(s.scans);
  w.Put(s.ekf.next_segment_id());
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(s.odometry.readings().size()));
  for (const OdometryReading& r : s.odometry.readings()) {
    w.Put(r.stamp);
    PutPose(w, r.pose);
  }
  PutPose(w, st.robot);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(st.segments.size()));
  for (const SegmentEntity& e : st.segments) PutSegment(w, e);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(st.frozen.size()));
  for (const FrozenSegment& f : st.frozen) {
    PutSegment(w, f.entity);
    for (int i = 0; i < 4; ++i) w.Put(f.line_covariance(i / 2, i % 2));
    w.Put(f.left_variance);
    w.Put(f.right_variance);
  }
  const int n = st.size();
  w.Put<std::int32_t>(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j <= i; ++j) w.Put(st.at(i, j));
  }
  Beside beside = Beside::kNothing;
  std::string extra;
  if (s.backend) {
    beside = Beside::kGraph;
    extra = s.backend->Serialize();
  } else if (s.localizer) {
    beside = Beside::kLocalizer;
    extra = s.localizer->Serialize();
  } else if (s.imported_grid) {
    beside = Beside::kImportedGrid;
    BinaryWriter g;
    PutGrid(g, *s.imported_grid);
    extra = g.Take();
  }
  w.Put<std::uint8_t>(static_cast<std::uint8_t>(beside));
  if (beside != Beside::kNothing) w.Put<std::uint64_t>(extra.size());
  std::string out = w.Take();
  out += extra;
  return out;
}

absl::StatusOr<std::unique_ptr<LaserSlam>> LaserSlam::FromCheckpoint(
    const SlamOptions& options, absl::string_view state, std::vector<PoseEstimate> trajectory,
    std::unique_ptr<MapLocalizer> localizer) {
  auto slam = std::make_unique<LaserSlam>(options, std::move(localizer));
  Impl& s = *slam->impl_;
  BinaryReader r(state);
  const auto corrupt = [](const char* what) {
    return absl::DataLossError(absl::StrCat("laser SLAM checkpoint is corrupt: ", what));
  };
  std::uint32_t magic = 0, version = 0;
  if (!r.Get(&magic) || magic != kMagic) return corrupt("not a checkpoint");
  if (!r.Get(&version) || version < 1 || version > kVersion) {
    return absl::FailedPreconditionError(absl::StrCat(
        "laser SLAM checkpoint version ", version, " is not supported (expected ", kVersion, ")"));
  }
  std::uint8_t have_scan = 0;
  std::uint64_t next_id = 0;
  std::uint32_t readings = 0;
  if (!r.Get(&have_scan) || !r.Get(&s.last_scan_stamp) || !PlausibleStamp(s.last_scan_stamp) ||
      !GetPose(r, &s.odometry_at_last_update) ||
      !r.Get(&s.revision) || !r.Get(&s.scans) || !r.Get(&next_id) || !r.Get(&readings) ||
      readings > OdometryBuffer::kCapacity) {
    return corrupt("header");
  }
  s.have_scan = have_scan != 0;
  s.ekf.set_next_segment_id(next_id);
  for (std::uint32_t i = 0; i < readings; ++i) {
    OdometryReading reading;
    if (!r.Get(&reading.stamp) || !GetPose(r, &reading.pose)) return corrupt("odometry");
    if (!s.odometry.Add(reading).ok()) return corrupt("odometry order");
  }
  SpState& st = s.ekf.state();
  std::uint32_t segments = 0;
  // Every count is checked against the bytes left before anything is allocated for it (a
  // corrupt count used to allocate gigabytes and abort; found by tests/fuzz). A stored segment
  // takes more than 8 bytes, a frozen one more than 48.
  if (!GetPose(r, &st.robot) || !r.Get(&segments) || segments > r.remaining() / 8) {
    return corrupt("robot");
  }
  std::vector<SegmentEntity> entities(segments);
  for (SegmentEntity& e : entities) {
    if (!GetSegment(r, &e)) return corrupt("segment");
  }
  std::uint32_t frozen = 0;
  if (!r.Get(&frozen) || frozen > 10000000 || frozen > r.remaining() / 48) {
    return corrupt("frozen segments");
  }
  std::vector<FrozenSegment> frozen_segments(frozen);
  for (FrozenSegment& f : frozen_segments) {
    if (!GetSegment(r, &f.entity)) return corrupt("frozen segment");
    for (int i = 0; i < 4; ++i) {
      if (!r.Get(&f.line_covariance(i / 2, i % 2))) return corrupt("frozen segment");
    }
    if (!r.Get(&f.left_variance) || !r.Get(&f.right_variance)) return corrupt("frozen segment");
  }
  std::int32_t n = 0;
  if (!r.Get(&n) || n < 3 || n > 1000000 ||
      r.remaining() / sizeof(double) < static_cast<size_t>(n) * (static_cast<size_t>(n) + 1) / 2) {
    return corrupt("state size");
  }
  for (const SegmentEntity& e : entities) {
    for (int k = 0; k < 4; ++k) {
      const bool needed = k < 2 || (k == 2 ? e.left_type : e.right_type) == EndpointType::kReal;
      if ((needed && (e.dof[k] < 3 || e.dof[k] >= n)) || (!needed && e.dof[k] != -1)) {
        return corrupt("segment dof index");
      }
    }
  }
  st.AddDofs(n - 3);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j <= i; ++j) {
      double v = 0.0;
      if (!r.Get(&v) || !std::isfinite(v)) return corrupt("covariance");
      st.at(i, j) = v;
      st.at(j, i) = v;
    }
  }
  if (version >= 2) {
    std::uint8_t beside = 0;
    std::uint64_t size = 0;
    if (!r.Get(&beside) || beside > 3) return corrupt("kind of the part beside the EKF");
    if (beside != 0 && (!r.Get(&size) || size != r.remaining())) return corrupt("part size");
    switch (static_cast<Beside>(beside)) {
      case Beside::kNothing:
        break;
      case Beside::kGraph:
        // A checkpoint with a graph resumed with the back end off keeps the EKF only (the
        // paper's method); one without a graph resumed with it on starts a graph there.
        if (s.backend) {
          absl::StatusOr<std::unique_ptr<MappingBackend>> backend =
              MappingBackend::Deserialize(options.mapping, r.Rest());
          if (!backend.ok()) return backend.status();
          s.backend = *std::move(backend);
        }
        break;
      case Beside::kLocalizer:
        if (!s.localizer) {
          return absl::FailedPreconditionError(
              "this checkpoint is a localization session's: resume it with its map");
        }
        if (absl::Status st = s.localizer->Restore(r.Rest()); !st.ok()) return st;
        break;
      case Beside::kImportedGrid: {
        BinaryReader g(r.Rest());
        OccupancyGrid grid;
        if (!GetGrid(g, &grid) || !g.done()) return corrupt("imported grid");
        s.imported_grid = std::move(grid);
        s.backend.reset();
        break;
      }
    }
    r.Skip(size);
  }
  if (!r.done()) return corrupt("trailing bytes");
  st.segments = std::move(entities);
  st.frozen = std::move(frozen_segments);
  s.trajectory = std::move(trajectory);
  return slam;
}

}  // namespace waymark::laser_slam
