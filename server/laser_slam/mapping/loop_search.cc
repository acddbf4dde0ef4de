#include "server/laser_slam/mapping/loop_search.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {

LoopQuery MakeLoopQuery(const PointCloud& points, const MappingOptions& options) {
  LoopQuery query;
  query.points = ThinPoints(points, options.point_cell);
  // The wide search scores half the points (one per 10 cm): the branch and bound costs in
  // proportion to them, and a wall sampled every 10 cm still pins the pose to the 5 cm grid. The
  // best pose is then refined and scored with all of them in a window of two cells.
  query.sparse = ThinPoints(query.points, 2.0 * options.point_cell);
  // Global searches run on a coarser grid first (coarse_search_factor times the cells, points and
  // angular step: about factor^3 fewer candidates), then refine on the fine grid.
  query.coarse =
      ThinPoints(query.points, 2.0 * options.coarse_search_factor * options.point_cell);
  query.coarser =
      ThinPoints(query.points, 4.0 * options.coarse_search_factor * options.point_cell);
  return query;
}

LoopMatch MatchSubmap(const LoopQuery& query, const SubmapGrids& grids, const Pose2& initial,
                      const SearchWindow& window, bool global, const MappingOptions& options) {
  LoopMatch out;
  Pose2 centre = initial;
  SearchWindow area = window;
  if (global) {
    // The whole submap: the fine grid's extent, every heading.
    const GridFrame frame = grids.fine_frame();
    const double resolution = options.grid_resolution;
    centre.x = frame.origin.x() + 0.5 * static_cast<double>(frame.width) * resolution;
    centre.y = frame.origin.y() + 0.5 * static_cast<double>(frame.height) * resolution;
    area.xy = 0.5 * static_cast<double>(std::max(frame.width, frame.height)) * resolution;
    area.theta = M_PI;
  }
  const bool coarse = options.coarse_search_factor > 1 && global;
  // A global search (and a windowed one with windowed_where_seen) keeps poses whose points where
  // the submap looked may reach min_score, if they are global_min_overlap of the query
  // (seen_mask.h); decided after the refinement.
  const bool partial = (global || options.windowed_where_seen) &&
                       options.global_min_overlap < 1.0 && grids.seen;
  const double floor = partial ? options.min_score * options.global_min_overlap : options.min_score;
  // With the lower floor the branch and bound keeps many more poses: the query is thinned
  // twice as much then (one point per 4 coarse_search_factor point_cell, on the same grid). In
  // cell reads that cost 1.4x (MIT Killian) and 3.3x (acapulco-high) a whole-query search, in
  // time 3x and 8x with the query of whole-query searches, and closed Killian as well (0.061
  // against 0.062 m). The fine refinement scores all the points.
  std::shared_ptr<const SearchPyramid> fine;
  const std::shared_ptr<const SearchPyramid> wide = coarse ? grids.coarse() : (fine = grids.fine());
  const PointCloud& wide_query =
      partial && coarse ? query.coarser : coarse ? query.coarse : query.sparse;
  std::optional<GridMatch> match = MatchInWindow(*wide, wide_query, centre, area, floor);
  if (!match) return out;
  const double lattice_score = match->lattice_score;
  if (!fine) fine = grids.fine();  // a global search's fine grid only when it found something
  const SearchWindow refine{2.0 * wide->base().resolution, coarse ? 0.04 : 0.02};
  match = MatchInWindow(*fine, query.points, match->pose, refine, floor);
  if (!match) return out;
  if (match->score < options.min_score) {
    // Below min_score over the whole query: accepted only on the points where the submap looked.
    const std::shared_ptr<const SeenMask> seen = partial ? grids.seen() : nullptr;
    if (!seen || seen->empty()) return out;
    const OverlapScore where_seen = ScoreWhereSeen(fine->base(), *seen, query.points, match->pose);
    if (where_seen.overlap < options.global_min_overlap || where_seen.score < options.min_score) {
      return out;
    }
    out.where_seen = true;
  }
  Eigen::Vector3d sigma(options.loop_sigma_xy, options.loop_sigma_xy, options.loop_sigma_theta);
  if (options.rival_ratio > 0.0) {
    // A rival beyond rival_far is another place that fits as well (refused), unless the score
    // stays as high all the way to it: then it is the same corridor slid along itself. A rival
    // nearer (but off the peak) or on that ridge is the same place, uncertain along one
    // direction: accepted, trusted only to the rival's offset. One search answers both (and
    // stops at a far rival).
    const double rival_score = options.rival_ratio * lattice_score;
    const Rivals rivals = FindRivals(*wide, wide_query, centre, area, match->pose,
                                     options.rival_exclusion, options.rival_far, rival_score);
    std::optional<Pose2> rival = rivals.near;
    if (rivals.far) {
      if (!options.loosen_ridges || !OnOneRidge(wide->base(), wide_query, match->pose,
                                                *rivals.far, options.rival_ratio)) {
        out.verdict = LoopMatch::Verdict::kAmbiguous;
        return out;
      }
      rival = rivals.far;
    }
    if (rival) {
      const Pose2 offset = Relative(match->pose, *rival);
      sigma = sigma.cwiseMax(
          Eigen::Vector3d(std::abs(offset.x), std::abs(offset.y), std::abs(offset.theta)));
      out.loosened = true;
    }
  }
  out.verdict = LoopMatch::Verdict::kAccepted;
  out.pose = match->pose;
  out.sigma = sigma;
  out.score = match->score;
  return out;
}

std::shared_ptr<const SearchPyramid> PyramidCache::Find(int submap, int coarsening) {
  const auto it = index_.find(Key(submap, coarsening));
  if (it == index_.end()) return nullptr;
  entries_.splice(entries_.end(), entries_, it->second);
  return it->second->pyramid;
}

void PyramidCache::Insert(int submap, int coarsening,
                          std::shared_ptr<const SearchPyramid> pyramid) {
  const std::int64_t key = Key(submap, coarsening);
  if (const auto it = index_.find(key); it != index_.end()) {
    bytes_ -= it->second->bytes;
    entries_.erase(it->second);
    index_.erase(it);
  }
  const size_t bytes = pyramid->bytes();
  entries_.push_back(Entry{key, std::move(pyramid), bytes});
  index_[key] = std::prev(entries_.end());
  bytes_ += bytes;
  // The newest stays even alone over the budget: the search in hand needs it.
  while (bytes_ > budget_ && entries_.size() > 1) {
    bytes_ -= entries_.front().bytes;
    index_.erase(entries_.front().key);
    entries_.pop_front();
  }
}

void PyramidCache::Erase(int submap) {
  frames_.erase(submap);
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (it->key / 64 != submap) {
      ++it;
      continue;
    }
    bytes_ -= it->bytes;
    index_.erase(it->key);
    it = entries_.erase(it);
  }
}

std::optional<GridFrame> PyramidCache::Frame(int submap) const {
  const auto it = frames_.find(submap);
  if (it == frames_.end()) return std::nullopt;
  return it->second;
}

}  // namespace waymark::laser_slam
