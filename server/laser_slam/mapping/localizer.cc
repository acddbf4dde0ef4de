#include "server/laser_slam/mapping/localizer.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/common/binary_io.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/input_bounds.h"
#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {
namespace {

constexpr std::uint32_t kMagic = 0x434c4d57;  // "WMLC"
constexpr std::uint32_t kVersion = 1;

}  // namespace

absl::Status ValidateLocalizationOptions(const LocalizationOptions& o) {
  for (const auto& [value, name] :
       {std::pair{o.initial_sigma_xy, "initial_sigma_xy"},
        {o.initial_sigma_theta, "initial_sigma_theta"}, {o.node_travel, "localize.node_travel"},
        {o.node_turn, "localize.node_turn"}, {o.point_range, "localize.point_range"},
        {o.point_cell, "localize.point_cell"}, {o.grid_resolution, "localize.grid_resolution"},
        {o.grid_sigma, "localize.grid_sigma"}, {o.track_sigma_xy, "localize.track_sigma_xy"},
        {o.track_sigma_theta, "localize.track_sigma_theta"},
        {o.lost_after_m, "localize.lost_after_m"}}) {
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
  return absl::OkStatus();
}

MapLocalizer::MapLocalizer(const LocalizationOptions& options, SearchPyramid pyramid,
                           SearchPyramid coarse)
    : options_(options), pyramid_(std::move(pyramid)), coarse_(std::move(coarse)) {}

absl::StatusOr<std::unique_ptr<MapLocalizer>> MapLocalizer::Create(
    const LocalizationOptions& options, const PointCloud& map_points) {
  if (absl::Status s = ValidateLocalizationOptions(options); !s.ok()) return s;
  if (map_points.empty()) {
    return absl::FailedPreconditionError("the map to localize on has no points");
  }
  const double k = options.global_coarsening;
  LikelihoodGrid fine = BuildLikelihoodGrid(ThinPoints(map_points, options.point_cell),
                                            options.grid_resolution, options.grid_sigma);
  LikelihoodGrid coarse = BuildLikelihoodGrid(ThinPoints(map_points, k * options.point_cell),
                                              k * options.grid_resolution, k * options.grid_sigma);
  return std::unique_ptr<MapLocalizer>(new MapLocalizer(
      options, SearchPyramid(fine, 6), SearchPyramid(coarse, options.global_depth)));
}

void MapLocalizer::Accept(std::uint64_t scan, double stamp, const Pose2& correction,
                          double score) {
  corrections_.emplace_back(scan, correction);
  localized_ = true;
  fix_travel_ = travel_;
  ++last_.fixes;
  last_.last_fix_stamp = stamp;
  last_.score = score;
}

LocalizationResult MapLocalizer::AddScan(std::uint64_t scan, double stamp, const Pose2& local,
                                         const PointCloud& points) {
  last_.global_search = false;
  last_.match_ms = 0.0;
  if (have_node_) {
    const Pose2 moved = Relative(last_node_local_, local);
    if (std::hypot(moved.x, moved.y) < options_.node_travel &&
        std::abs(moved.theta) < options_.node_turn) {
      last_.localized = localized_;
      return last_;
    }
    travel_ += std::hypot(moved.x, moved.y);
  }
  const auto start = Clock::now();
  have_node_ = true;
  last_node_local_ = local;
  recent_.push_back({local, ThinPoints(points, options_.point_cell)});
  while (static_cast<int>(recent_.size()) > options_.query_nodes) recent_.pop_front();
  // The points of the newest `count` nodes, in the newest one's frame.
  const auto query_of = [&](int count) {
    PointCloud query;
    for (int i = std::max(0, static_cast<int>(recent_.size()) - count);
         i < static_cast<int>(recent_.size()); ++i) {
      AppendTransformed(recent_[i].points, Relative(local, recent_[i].local), &query);
    }
    return ThinPoints(query, options_.point_cell);
  };

  if (localized_ && travel_ - fix_travel_ > options_.lost_after_m) localized_ = false;
  const bool from_initial = !localized_ && corrections_.empty() && options_.initial_pose;
  last_.score = 0.0;
  if (from_initial && static_cast<int>(recent_.size()) < options_.track_query_nodes) {
    // A known start: dead reckoning from it until there are enough scans to match. One scan
    // searched over the start's 3 sigma (1.5 m) slides along a corridor (ACES from scan 2000:
    // 342 poses off by more than 0.5 m when the first scan was matched alone).
  } else if (localized_ || from_initial) {
    const Pose2 correction =
        corrections_.empty() ? *options_.initial_pose : corrections_.back().second;
    const double untied = travel_ - fix_travel_;
    SearchWindow window;
    window.xy = 3.0 * (from_initial ? options_.initial_sigma_xy
                                    : options_.track_sigma_xy + options_.drift_xy_per_m * untied);
    window.theta =
        3.0 * (from_initial ? options_.initial_sigma_theta
                            : options_.track_sigma_theta + options_.drift_theta_per_m * untied);
    // The first match from a given start searches a wide window: it must score as a global fix.
    const double min_score = from_initial ? options_.global_min_score : options_.min_score;
    const std::optional<GridMatch> match =
        MatchInWindow(pyramid_, query_of(options_.track_query_nodes), Compose(correction, local),
                      window, min_score);
    if (match && match->score >= min_score) {
      Accept(scan, stamp, Compose(match->pose, Invert(local)), match->score);
    } else if (match) {
      last_.score = match->score;
    }
  } else {
    last_.global_search = true;
    const LikelihoodGrid& grid = coarse_.base();
    const Pose2 centre{grid.origin.x() + 0.5 * grid.width * grid.resolution,
                       grid.origin.y() + 0.5 * grid.height * grid.resolution, 0.0};
    const SearchWindow whole{0.5 * std::max(grid.width, grid.height) * grid.resolution, M_PI};
    const PointCloud query = query_of(options_.query_nodes);
    std::optional<GridMatch> match =
        MatchInWindow(coarse_, ThinPoints(query, grid.resolution), centre, whole,
                      options_.global_min_score);
    if (match) {
      // Refined on the fine grid, where the score is comparable with the tracking one.
      const SearchWindow refine{2.0 * grid.resolution, 0.05};
      match = MatchInWindow(pyramid_, query, match->pose, refine, options_.global_min_score);
    }
    if (match && match->score >= options_.global_min_score) {
      last_.score = match->score;
      const Pose2 correction = Compose(match->pose, Invert(local));
      if (pending_global_) {
        // The motion between the two searches, as odometry saw it, must carry the first
        // match onto the second.
        const Pose2 predicted = Compose(*pending_global_, local);
        const Pose2 difference = Relative(predicted, match->pose);
        if (std::hypot(difference.x, difference.y) <= options_.global_agreement_xy &&
            std::abs(difference.theta) <= options_.global_agreement_theta) {
          Accept(scan, stamp, correction, match->score);
          pending_global_.reset();
        } else {
          pending_global_ = correction;
        }
      } else {
        pending_global_ = correction;
      }
    } else {
      pending_global_.reset();
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
  localized_ = localized != 0;
  have_node_ = have_node != 0;
  last_.fixes = fixes;
  last_.localized = localized_;
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam
