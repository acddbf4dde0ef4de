#include "server/laser_slam/mapping/mapping_options.h"

#include "absl/strings/str_cat.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {

absl::Status ValidateMappingOptions(const MappingOptions& o) {
  if (o.threads < 0 || o.threads > 1) {
    return absl::InvalidArgumentError(absl::StrCat("mapping.threads must be 0 or 1, got ", o.threads));
  }
  for (const auto& [value, name] :
       {std::pair{o.node_travel, "mapping.node_travel"}, {o.node_turn, "mapping.node_turn"},
        {o.point_range, "mapping.point_range"}, {o.point_cell, "mapping.point_cell"},
        {o.grid_resolution, "mapping.grid_resolution"}, {o.grid_sigma, "mapping.grid_sigma"},
        {o.max_window_xy, "mapping.max_window_xy"},
        {o.candidate_distance, "mapping.candidate_distance"},
        {o.loop_window_sigmas, "mapping.loop_window_sigmas"},
        {o.rival_exclusion, "mapping.rival_exclusion"}, {o.rival_far, "mapping.rival_far"},
        {o.chain_sigma_xy, "mapping.chain_sigma_xy"},
        {o.chain_sigma_theta, "mapping.chain_sigma_theta"},
        {o.loop_sigma_xy, "mapping.loop_sigma_xy"},
        {o.loop_sigma_theta, "mapping.loop_sigma_theta"}, {o.huber_scale, "mapping.huber_scale"},
        {o.local_window_sigmas, "mapping.local_window_sigmas"},
        {o.local_sigma_xy, "mapping.local_sigma_xy"},
        {o.local_sigma_theta, "mapping.local_sigma_theta"},
        {o.local_points_per_observation, "mapping.local_points_per_observation"},
        {o.outlier_residual, "mapping.outlier_residual"}}) {
    if (absl::Status s = Positive(value, name); !s.ok()) return s;
  }
  for (const auto& [value, name] :
       {std::pair{o.min_loop_travel, "mapping.min_loop_travel"},
        {o.loop_window_min_xy, "mapping.loop_window_min_xy"},
        {o.loop_window_min_theta, "mapping.loop_window_min_theta"},
        {o.rival_ratio, "mapping.rival_ratio"},
        {o.chain_sigma_xy_per_m, "mapping.chain_sigma_xy_per_m"},
        {o.chain_sigma_theta_per_m, "mapping.chain_sigma_theta_per_m"},
        {o.chain_sigma_theta_per_rad, "mapping.chain_sigma_theta_per_rad"},
        {o.local_window_min_xy, "mapping.local_window_min_xy"},
        {o.local_window_min_theta, "mapping.local_window_min_theta"}}) {
    if (absl::Status s = NonNegative(value, name); !s.ok()) return s;
  }
  if (o.min_score <= 0.0 || o.min_score >= 1.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.min_score must be in (0, 1), got ", o.min_score));
  }
  if (!(o.global_min_overlap > 0.0 && o.global_min_overlap <= 1.0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.global_min_overlap must be in (0, 1], got ", o.global_min_overlap));
  }
  if (o.local_min_score <= 0.0 || o.local_min_score >= 1.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.local_min_score must be in (0, 1), got ", o.local_min_score));
  }
  if (!(o.local_wide_window_xy > 0.0) || o.local_wide_window_xy > o.max_window_xy) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.local_wide_window_xy must be in (0, max_window_xy], got ", o.local_wide_window_xy));
  }
  if (!(o.local_wide_window_theta > 0.0) || o.local_wide_window_theta > M_PI) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.local_wide_window_theta must be in (0, pi], got ", o.local_wide_window_theta));
  }
  if (o.local_map_nodes < 1 || o.local_map_nodes > 200) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.local_map_nodes must be in [1, 200], got ", o.local_map_nodes));
  }
  if (o.local_window_min_xy > o.max_window_xy) {
    return absl::InvalidArgumentError("mapping.local_window_min_xy must not exceed mapping.max_window_xy");
  }
  if (o.prune_after_submaps < 1 || o.prune_after_submaps > 1000) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.prune_after_submaps must be in [1, 1000], got ", o.prune_after_submaps));
  }
  if (o.prune_min_ties < 1 || o.prune_min_ties > 1000) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.prune_min_ties must be in [1, 1000], got ", o.prune_min_ties));
  }
  if (!(o.prune_max_new_fraction >= 0.0 && o.prune_max_new_fraction <= 1.0)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.prune_max_new_fraction must be in [0, 1], got ", o.prune_max_new_fraction));
  }
  if (!(o.prune_cell >= 0.01 && o.prune_cell <= 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.prune_cell must be in [0.01, 10] m, got ", o.prune_cell));
  }
  if (o.submap_nodes < 2 || o.submap_nodes > 1000) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.submap_nodes must be in [2, 1000], got ", o.submap_nodes));
  }
  if (o.rival_ratio >= 1.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.rival_ratio must be in [0, 1), got ", o.rival_ratio));
  }
  if (o.coarse_search_factor < 1 || o.coarse_search_factor > 4) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.coarse_search_factor must be in [1, 4], got ", o.coarse_search_factor));
  }
  if (o.global_search_every_nodes < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mapping.global_search_every_nodes must be >= 1, got ", o.global_search_every_nodes));
  }
  if (o.search_every_nodes < 1 || o.query_nodes < 1 || o.query_nodes > 50 ||
      o.max_candidates < 1 || o.optimize_every_closures < 1 || o.max_iterations < 1) {
    return absl::InvalidArgumentError(
        "mapping.search_every_nodes, max_candidates, optimize_every_closures and max_iterations "
        "must be >= 1, query_nodes in [1, 50]");
  }
  if (o.search_depth < 0 || o.search_depth > 10) {
    return absl::InvalidArgumentError(
        absl::StrCat("mapping.search_depth must be in [0, 10], got ", o.search_depth));
  }
  if (o.max_window_xy / o.grid_resolution > 4000.0) {
    return absl::InvalidArgumentError("mapping.max_window_xy is too large for the grid resolution");
  }
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam
