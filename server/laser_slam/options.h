#ifndef WAYMARK_SERVER_LASER_SLAM_OPTIONS_H_
#define WAYMARK_SERVER_LASER_SLAM_OPTIONS_H_

// Parameters of the line-segment EKF SLAM (METHODS.md section 2). Where the paper gives a value
// (the 6 m range) it is the default; every other default is ours and its comment says why.

#include "absl/status/status.h"
#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/mapping/mapping_options.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct LineExtractionOptions {
  // Readings beyond this range are dropped before fitting (paper: 6 m).
  double max_range = 6.0;
  // Readings closer than this are dropped (the laser's housing, the robot's own parts).
  double min_range = 0.05;
  // Range noise of one reading, 1 sigma (SICK LMS200 datasheet: about 1 cm at short range).
  double range_sigma = 0.01;
  // Bearing noise of one reading, 1 sigma (half a 0.25 degree quantum, generously).
  double bearing_sigma = 0.002;
  // Split the scan where consecutive points are further apart than
  // discontinuity_abs + discontinuity_rel * range (m).
  double discontinuity_abs = 0.15;
  double discontinuity_rel = 0.05;
  // Split-and-merge: split a cluster where a point lies further than this from the chord (m).
  double split_distance = 0.05;
  // A segment needs at least this many points and this length (m).
  int min_points = 6;
  double min_length = 0.3;
  // Drop segments whose incidence angle to the laser beams is below this (rad): nearly parallel
  // to the beams, their points are sparse and biased (paper step 3). 15 degrees.
  double min_incidence = 0.26;
  // Merge neighbouring segments of one cluster when their lines agree within these tolerances.
  double merge_angle = 0.05;
  double merge_distance = 0.05;
};

// Wheel-odometry error model for the prediction step: standard deviations grow with the distance
// travelled and the angle turned between two scans (the usual Thrun et al. motion model,
// per-scan increments). Defaults suit a Pioneer-class differential drive on an indoor floor.
struct OdometryNoise {
  double xy_per_m = 0.05;        // m of translational error per m travelled
  double theta_per_rad = 0.2;    // rad of heading error per rad turned (ACES/Intel: 0.05 let
                                 // the filter trust turns too much and lose matches)
  double theta_per_m = 0.03;     // rad of heading error per m travelled (wheel slip, width error)
  double xy_min = 0.002;         // floor on every increment (m)
  double theta_min = 0.002;      // floor on every increment (rad)
};

struct EkfOptions {
  // Model error added to every observed line and endpoint (1 sigma), on top of the fit's own
  // covariance, which only knows the random range noise. Real walls are not perfectly straight,
  // mixed pixels and the logs' 1 cm range quantisation bias fits, and the same wall seen twice
  // differs by more than the fit covariance says; without a floor the filter becomes
  // overconfident and duplicates walls instead of matching them. Values from the ACES/Intel logs
  // (ours): the spread of one wall's fit between consecutive scans of a standing robot.
  double line_offset_floor = 0.02;   // m, along the line normal
  double line_angle_floor = 0.02;    // rad
  double endpoint_floor = 0.05;      // m, along the line
  // Mahalanobis gate for matching an observed line to a map line: chi-square with 2 degrees of
  // freedom; 16 = 99.97 % confidence. The textbook 9.21 (99 %) rejected too many true matches on
  // the ACES and Intel logs (0.24 vs 0.17 m relations error on ACES): the fit covariance plus the
  // floors above still underrate real model error now and then, and a missed match costs more
  // (a duplicate wall, drift) than a slightly wide gate.
  double match_chi2 = 16.0;
  // Observed and map segments must overlap along the line, allowing this gap (m), so that a wall
  // seen further along still matches and extends the map segment.
  double overlap_margin = 0.3;
  // Gate for an endpoint-position measurement (1 dof, 99 %: 6.63); beyond it the endpoint row is
  // left out of the update instead of corrupting the line.
  double endpoint_chi2 = 6.63;
  // Two map segments are merged when they pass this joint gate (2 dof) and overlap or nearly touch.
  double merge_chi2 = 9.21;
  double merge_gap = 0.3;
  // A new segment stays tentative until it has been matched this many times in total; one that is
  // still tentative confirm_window scans after it appeared is removed (marginalised out). Clutter
  // (people's legs, chairs, mixed pixels) rarely repeats; walls do. Keeps the state, and with it
  // the quadratic update, to the structure of the building (ours).
  int confirm_observations = 3;
  int confirm_window = 10;
  // The active window that bounds the cost of an update (the textbook EKF update is quadratic in
  // the state). A segment further than active_radius from the robot that has not been matched for
  // freeze_after_scans scans is marginalised out of the filter ("frozen"): it stays in the map
  // with its last estimate and marginal covariance, and the remaining state is still the exact
  // marginal, so the filter stays consistent; what is given up is closing a loop against frozen
  // segments (a revisited area is mapped again). When more than max_active_segments remain, the
  // least recently matched are frozen first (ours).
  double active_radius = 12.0;
  int freeze_after_scans = 20;
  int max_active_segments = 200;
  // Try merges every this many scans (the check is over segment pairs near the robot).
  int merge_every_scans = 5;
  // Map segments further than this from the robot are not considered for matching (m): they cannot
  // be seen within the range used, and skipping them keeps association linear in nearby segments.
  double association_radius = 10.0;
  // Scans whose odometry says the robot moved less than this since the last processed scan are
  // skipped (0 = process every scan). Standing still adds information only about the same walls.
  double min_travel = 0.0;
  double min_turn = 0.0;
};

struct SlamOptions {
  LineExtractionOptions extraction;
  OdometryNoise odometry;
  EkfOptions ekf;
  // Pose of the laser on the robot (robot frame).
  Pose2 laser_pose;
  // Active exploration; mode kPassive (the default) suggests nothing.
  ExplorationOptions exploration;
  // The loop-closing back end beside the EKF; mapping.enabled = false is the paper's method alone.
  MappingOptions mapping;
};

absl::Status ValidateSlamOptions(const SlamOptions& options);
absl::Status ValidateScanGeometry(const ScanGeometry& geometry);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_OPTIONS_H_
