#include "server/laser_slam/mapping/localizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/common/binary_io.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/input_bounds.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {
namespace {

constexpr std::uint32_t kMagic = 0x434c4d57;  // "WMLC"
constexpr std::uint32_t kVersion = 1;
// Half the band of headings (rad) a tracking match's rival is looked for in, around the match's.
constexpr double kTrackRivalBand = 0.02;

}  // namespace

absl::Status ValidateLocalizationOptions(const LocalizationOptions& o) {
  for (const auto& [value, name] :
       {std::pair{o.initial_sigma_xy, "initial_sigma_xy"},
        {o.initial_sigma_theta, "initial_sigma_theta"}, {o.node_travel, "localize.node_travel"},
        {o.node_turn, "localize.node_turn"}, {o.point_range, "localize.point_range"},
        {o.point_cell, "localize.point_cell"}, {o.grid_resolution, "localize.grid_resolution"},
        {o.grid_sigma, "localize.grid_sigma"}, {o.track_sigma_xy, "localize.track_sigma_xy"},
        {o.track_sigma_theta, "localize.track_sigma_theta"},
        {o.lost_after_m, "localize.lost_after_m"}, {o.rival_xy, "localize.rival_xy"},
        {o.rival_theta, "localize.rival_theta"}, {o.track_rival_xy, "localize.track_rival_xy"},
        {o.global_query_cell, "localize.global_query_cell"}}) {
    if (absl::Status s = Positive(value, name); !s.ok()) return s;
  }
  if (o.initial_sigma_xy > 100.0 || o.initial_sigma_theta > M_PI) {
    return absl::InvalidArgumentError(
        "initial_sigma_xy must be at most 100 m and initial_sigma_theta at most pi (leave the "
        "initial pose unset for an unknown start)");
  }
  if (o.initial_pose && !(std::isfinite(o.initial_pose->x) && std::isfinite(o.initial_pose->y) &&
                          std::isfinite(o.initial_pose->theta))) {
    return absl::InvalidArgumentError("initial_pose must be finite");
  }
  if (o.query_nodes < 1 || o.query_nodes > 50 || o.track_query_nodes < 1 ||
      o.track_query_nodes > o.query_nodes || o.global_depth < 0 || o.global_depth > 10 ||
      o.global_coarsening < 1 || o.global_coarsening > 8 ||
      !(o.min_score > 0 && o.min_score < 1) ||
      !(o.global_min_score > 0 && o.global_min_score < 1)) {
    return absl::InvalidArgumentError(
        "localize: query_nodes must be in [1, 50], global_depth in [0, 10], scores in (0, 1)");
  }
  if (!(o.rival_floor > 0 && o.rival_floor <= o.global_rival_ratio && o.global_rival_ratio <= 1)) {
    return absl::InvalidArgumentError(
        "localize: rival_floor and global_rival_ratio must satisfy 0 < rival_floor <= "
        "global_rival_ratio <= 1 (1 refuses only a rival that scores as well as the match)");
  }
  if (o.threads < 0 || o.threads > 1 || o.global_reads_per_scan < 1000 ||
      o.global_reads_per_scan > (std::int64_t{1} << 60)) {
    return absl::InvalidArgumentError(
        "localize: threads must be 0 or 1 and global_reads_per_scan in [1000, 2^60]");
  }
  return absl::OkStatus();
}

MapLocalizer::MapLocalizer(const LocalizationOptions& options, SearchPyramid pyramid,
                           SearchPyramid coarse)
    : options_(options),
      pyramid_(std::move(pyramid)),
      coarse_(std::move(coarse)),
      // On the thread, a scan waits only while the search is more than two scans' budgets behind.
      global_(options.threads, 2 * options.global_reads_per_scan) {
  last_.state =
      options_.initial_pose ? LocalizationState::kFromStart : LocalizationState::kSearching;
}

MapLocalizer::~MapLocalizer() = default;

absl::StatusOr<std::unique_ptr<MapLocalizer>> MapLocalizer::Create(
    const LocalizationOptions& options, const PointCloud& map_points) {
  if (absl::Status s = ValidateLocalizationOptions(options); !s.ok()) return s;
  if (map_points.empty()) {
    return absl::FailedPreconditionError("the map to localize on has no points");
  }
  const double k = options.global_coarsening;
  // A whole map, not a submap: as large as an occupancy grid may be.
  LikelihoodGrid fine = BuildLikelihoodGrid(ThinPoints(map_points, options.point_cell),
                                            options.grid_resolution, options.grid_sigma,
                                            kMaxOccupancyCells);
  if (fine.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the map to localize on spans more than ", kMaxOccupancyCells, " cells at ",
        options.grid_resolution, " m"));
  }
  LikelihoodGrid coarse = BuildLikelihoodGrid(ThinPoints(map_points, k * options.point_cell),
                                              k * options.grid_resolution, k * options.grid_sigma,
                                              kMaxOccupancyCells);
  return std::unique_ptr<MapLocalizer>(new MapLocalizer(
      options, SearchPyramid(fine, 6), SearchPyramid(coarse, options.global_depth)));
}

void MapLocalizer::Accept(std::uint64_t scan, double stamp, const Pose2& correction,
                          double score, double travel) {
  corrections_.emplace_back(scan, correction);
  localized_ = true;
  fix_travel_ = travel;
  ++last_.fixes;
  last_.last_fix_stamp = stamp;
  last_.score = score;
  last_.state = LocalizationState::kTracking;
}

PointCloud MapLocalizer::Query(int count, const Pose2& local) const {
  PointCloud query;
  for (int i = std::max(0, static_cast<int>(recent_.size()) - count);
       i < static_cast<int>(recent_.size()); ++i) {
    AppendTransformed(recent_[i].points, Relative(local, recent_[i].local), &query);
  }
  return ThinPoints(query, options_.point_cell);
}

namespace {

// The rival fields of `result`: the rival's score over the match's (both on one grid, both on its
// lattice or both refined) and where it is from the match; none with no rival.
void SetRival(const Pose2& match, double match_score, const std::optional<GridMatch>& rival,
              double rival_score, LocalizationResult* result) {
  result->rival_ratio = 0.0;
  result->rival_distance = 0.0;
  result->rival_angle = 0.0;
  if (!rival || !(match_score > 0)) return;
  result->rival_ratio = std::min(1.0, rival_score / match_score);
  result->rival_distance = std::hypot(rival->pose.x - match.x, rival->pose.y - match.y);
  result->rival_angle = std::abs(std::remainder(rival->pose.theta - match.theta, 2 * M_PI));
}

}  // namespace

void MapLocalizer::Track(std::uint64_t scan, double stamp, const Pose2& local, bool from_initial) {
  const Pose2 correction =
      corrections_.empty() ? *options_.initial_pose : corrections_.back().second;
  const double untied = travel_ - fix_travel_;
  SearchWindow window;
  window.xy = 3.0 * (from_initial ? options_.initial_sigma_xy
                                  : options_.track_sigma_xy + options_.drift_xy_per_m * untied);
  window.theta =
      3.0 * (from_initial ? options_.initial_sigma_theta
                          : options_.track_sigma_theta + options_.drift_theta_per_m * untied);
  // The first match from a given start searches a wide window: it must score as a global fix,
  // and be unique in it as one (a corridor within 3 sigma of the start slides along itself).
  const double min_score = from_initial ? options_.global_min_score : options_.min_score;
  const PointCloud query = Query(options_.track_query_nodes, local);
  const Pose2 initial = Compose(correction, local);
  const std::optional<GridMatch> match =
      MatchInWindow(pyramid_, query, initial, window, min_score);
  last_.score = match ? match->score : 0.0;
  SetRival(Pose2{}, 0.0, std::nullopt, 0.0, &last_);
  if (!match || match->score < min_score) return;
  // Its rival. From a known start, as a global match's: another place in the window. Tracking:
  // how far the match could slide (a corridor seen without its ends), the best pose at the
  // match's heading farther than track_rival_xy from it. Searched over every heading of the
  // window it cost twice the match itself (MIT CSAIL, 361 beams: 2.0 M cell reads a match against
  // 0.9 M); over a band of +-kTrackRivalBand around the match's heading, 0.7 M.
  const Pose2 best = match->pose;
  const double rival_min_score = options_.rival_floor * match->lattice_score;
  std::optional<BranchAndBoundSearch> rival_search;
  if (from_initial) {
    const double far_xy = options_.rival_xy, far_theta = options_.rival_theta;
    rival_search.emplace(pyramid_, query, initial, window, rival_min_score, /*first_only=*/false,
                         [best, far_xy, far_theta](const Pose2& q) {
                           return std::hypot(q.x - best.x, q.y - best.y) > far_xy ||
                                  std::abs(std::remainder(q.theta - best.theta, 2 * M_PI)) >
                                      far_theta;
                         });
  } else {
    const double far_xy = options_.track_rival_xy;
    rival_search.emplace(pyramid_, query, Pose2{initial.x, initial.y, best.theta},
                         SearchWindow{window.xy, kTrackRivalBand}, rival_min_score,
                         /*first_only=*/false, [best, far_xy](const Pose2& q) {
                           return std::hypot(q.x - best.x, q.y - best.y) > far_xy;
                         });
  }
  rival_search->Resume(std::numeric_limits<std::int64_t>::max());
  const std::optional<GridMatch> rival = rival_search->result();
  SetRival(match->pose, match->lattice_score, rival, rival ? rival->lattice_score : 0.0, &last_);
  if (from_initial && last_.rival_ratio >= options_.global_rival_ratio) {
    last_.state = LocalizationState::kAmbiguous;
    return;
  }
  Accept(scan, stamp, Compose(match->pose, Invert(local)), match->score, travel_);
}

void MapLocalizer::TakeGlobalAnswer(const GlobalSearch& search) {
  const GlobalSearchOutcome& outcome = search.outcome();
  last_.global_search = true;
  last_.score = outcome.match ? outcome.match->score : 0.0;
  SetRival(Pose2{}, 0.0, std::nullopt, 0.0, &last_);
  if (!outcome.match) {
    pending_global_.reset();
    last_.state = LocalizationState::kSearching;
    return;
  }
  SetRival(outcome.match->pose, outcome.match->score, outcome.rival,
           outcome.rival ? outcome.rival->score : 0.0, &last_);
  if (last_.rival_ratio >= options_.global_rival_ratio) {
    // Either place could be the robot's: neither this match nor one waiting for agreement may
    // become a fix (two searches agreeing on the same wrong room is the failure this prevents).
    pending_global_.reset();
    last_.state = LocalizationState::kAmbiguous;
    return;
  }
  const Pose2 correction = Compose(outcome.match->pose, Invert(search.local()));
  if (pending_global_) {
    // The motion between the two searches, as odometry saw it, must carry the first match onto
    // the second. Searches spread over scans are metres apart, yet the fixed agreement holds:
    // widened by the drift over those metres (0.3 m + 2 %/m, 0.1 rad + 0.005 rad/m) it let wrong
    // pairs through on MIT CSAIL (0.68 m apart after 22.5 m: a fix 1.1 m off that tracking then
    // lost), and the EKF's drift over a few metres is well inside it.
    const Pose2 predicted = Compose(*pending_global_, search.local());
    const Pose2 difference = Relative(predicted, outcome.match->pose);
    if (std::hypot(difference.x, difference.y) <= options_.global_agreement_xy &&
        std::abs(difference.theta) <= options_.global_agreement_theta) {
      pending_global_.reset();
      // The fix belongs to the searched node's scan: the scans answered since then (not
      // localized) move with it in GetTrajectory, as the scans before a first fix do, and the
      // tracking window grows with the metres driven since that node.
      Accept(search.scan(), search.stamp(), correction, outcome.match->score, search_travel_);
      return;
    }
  }
  pending_global_ = correction;
  last_.state = LocalizationState::kConfirming;
}

LocalizationResult MapLocalizer::AddScan(std::uint64_t scan, double stamp, const Pose2& local,
                                         const PointCloud& points) {
  const auto start = Clock::now();
  last_.global_search = false;
  last_.match_ms = 0.0;
  bool node = true;
  if (have_node_) {
    const Pose2 moved = Relative(last_node_local_, local);
    node = std::hypot(moved.x, moved.y) >= options_.node_travel ||
           std::abs(moved.theta) >= options_.node_turn;
    if (node) travel_ += std::hypot(moved.x, moved.y);
  }
  if (global_.busy()) {
    // Every scan, node or not, gives the search under way its budget: inline that much work, on
    // the thread that much more. Taken before this scan's node so that a fix it brings is
    // tracked to this node at once (the search's node may be metres behind).
    last_.global_search = true;
    global_.Advance(options_.global_reads_per_scan);
    if (std::unique_ptr<GlobalSearch> answered = global_.TakeFinished()) {
      TakeGlobalAnswer(*answered);
    }
  }
  if (node) {
    have_node_ = true;
    last_node_local_ = local;
    recent_.push_back({local, ThinPoints(points, options_.point_cell)});
    while (static_cast<int>(recent_.size()) > options_.query_nodes) recent_.pop_front();
    if (localized_ && travel_ - fix_travel_ > options_.lost_after_m) {
      localized_ = false;
      last_.state = LocalizationState::kSearching;
    }
    const bool from_initial = !localized_ && corrections_.empty() && options_.initial_pose;
    if (from_initial && static_cast<int>(recent_.size()) < options_.track_query_nodes) {
      // A known start: dead reckoning from it until there are enough scans to match. One scan
      // searched over the start's 3 sigma (1.5 m) slides along a corridor (ACES from scan 2000:
      // 342 poses off by more than 0.5 m when the first scan was matched alone).
      last_.state = LocalizationState::kFromStart;
    } else if (localized_ || from_initial) {
      Track(scan, stamp, local, from_initial);
    } else if (!global_.busy()) {
      // A new search with the newest nodes (its budget comes from the next scan on); the one
      // before (if any) was answered already. While it runs the robot stays not localized, and
      // the nodes keep coming for the next search.
      GlobalSearchSettings settings;
      settings.min_score = options_.global_min_score;
      settings.rival_xy = options_.rival_xy;
      settings.rival_theta = options_.rival_theta;
      settings.rival_floor = options_.rival_floor;
      settings.query_cell = options_.global_query_cell;
      search_travel_ = travel_;
      last_.global_search = true;
      global_.Start(std::make_unique<GlobalSearch>(coarse_, pyramid_, settings, scan, stamp, local,
                                                   Query(options_.query_nodes, local)));
    }
  }
  last_.localized = localized_;
  last_.match_ms = MsSince(start);
  return last_;
}

Pose2 MapLocalizer::ToMap(std::uint64_t scan, const Pose2& local) const {
  if (corrections_.empty()) return options_.initial_pose ? Compose(*options_.initial_pose, local) : local;
  auto it = std::upper_bound(
      corrections_.begin(), corrections_.end(), scan,
      [](std::uint64_t s, const std::pair<std::uint64_t, Pose2>& c) { return s < c.first; });
  if (it != corrections_.begin()) --it;
  return Compose(it->second, local);
}

std::string MapLocalizer::Serialize() const {
  BinaryWriter w;
  w.Put(kMagic);
  w.Put(kVersion);
  w.Put<std::uint8_t>(localized_);
  w.Put<std::uint8_t>(have_node_);
  for (double v : {last_node_local_.x, last_node_local_.y, last_node_local_.theta, travel_,
                   fix_travel_, last_.last_fix_stamp}) {
    w.Put(v);
  }
  w.Put<std::int32_t>(last_.fixes);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(corrections_.size()));
  for (const auto& [scan, c] : corrections_) {
    w.Put(scan);
    w.Put(c.x);
    w.Put(c.y);
    w.Put(c.theta);
  }
  return w.Take();
}

absl::Status MapLocalizer::Restore(absl::string_view bytes) {
  const auto corrupt = [](const char* what) {
    return absl::DataLossError(absl::StrCat("localization checkpoint is corrupt: ", what));
  };
  BinaryReader r(bytes);
  std::uint32_t magic = 0, version = 0, count = 0;
  std::uint8_t localized = 0, have_node = 0;
  std::int32_t fixes = 0;
  if (!r.Get(&magic) || magic != kMagic || !r.Get(&version) || version != kVersion) {
    return corrupt("header");
  }
  if (!r.Get(&localized) || !r.Get(&have_node) || !r.Get(&last_node_local_.x) ||
      !r.Get(&last_node_local_.y) || !r.Get(&last_node_local_.theta) ||
      !PlausibleMapPose(last_node_local_) || !r.Get(&travel_) ||
      !r.Get(&fix_travel_) || !r.Get(&last_.last_fix_stamp) || !r.Get(&fixes) || fixes < 0 ||
      !r.Get(&count) || count > 100000000 ||
      // Checked against the bytes left before allocating (a scan number and a pose each), as
      // the pose graph's counts are (mapping_backend.cc).
      count > r.remaining() / (sizeof(std::uint64_t) + 3 * sizeof(double))) {
    return corrupt("state");
  }
  corrections_.resize(count);
  std::uint64_t previous = 0;
  for (auto& [scan, c] : corrections_) {
    // Within a map's bounds (input_bounds.h), as the pose graph's poses are.
    if (!r.Get(&scan) || !r.Get(&c.x) || !r.Get(&c.y) || !r.Get(&c.theta) || scan < previous ||
        !PlausibleMapPose(c)) {
      return corrupt("correction");
    }
    previous = scan;
  }
  if (!r.done()) return corrupt("trailing bytes");
  // A search under way belonged to the state replaced here.
  global_.Cancel();
  pending_global_.reset();
  recent_.clear();
  localized_ = localized != 0;
  have_node_ = have_node != 0;
  last_.fixes = fixes;
  last_.localized = localized_;
  last_.state = localized_               ? LocalizationState::kTracking
                : corrections_.empty() && options_.initial_pose ? LocalizationState::kFromStart
                                                                : LocalizationState::kSearching;
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam
