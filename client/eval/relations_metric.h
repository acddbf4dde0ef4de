#ifndef WAYMARK_CLIENT_EVAL_RELATIONS_METRIC_H_
#define WAYMARK_CLIENT_EVAL_RELATIONS_METRIC_H_

// The relations metric of Kummerle et al., "On measuring the accuracy of SLAM algorithms",
// Autonomous Robots 27(4), 2009. A relation (t1, t2, delta*) is the true pose of the robot at t2
// in the frame of the robot at t1. With the estimated poses p1, p2 at those stamps:
//   delta_est = inv(p1) (+) p2,   e = inv(delta*) (+) delta_est,
//   translational error = hypot(e_x, e_y) (m),  rotational error = |normalise(e_theta)| (deg).
// Reported: mean and standard deviation (population, i.e. divided by n) of the absolute and of the
// squared errors over the relations whose two poses were found.

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {

struct Relation {
  double t1 = 0;
  double t2 = 0;
  Pose2 delta;  // x, y, yaw of the .relations line (z, roll, pitch ignored: planar)
};

// `.relations` text: `t1 t2 x y z roll pitch yaw` per line, `#` comments allowed.
absl::StatusOr<std::vector<Relation>> ParseRelations(const std::string& text);
absl::StatusOr<std::vector<Relation>> ReadRelationsFile(const std::string& path);

struct MeanStd {
  double mean = 0;
  double std = 0;
};
MeanStd ComputeMeanStd(const std::vector<double>& values);

struct RelationsResult {
  int relations = 0;       // in the file
  int relations_used = 0;  // both poses found
  int missing_t1 = 0;      // no pose within the tolerance of t1 (or of both stamps)
  int missing_t2 = 0;      // t1 found, t2 not
  MeanStd trans_abs;       // m
  MeanStd trans_sq;        // m^2
  MeanStd rot_abs_deg;     // deg
  MeanStd rot_sq_deg2;     // deg^2
  double trans_abs_max = 0;
  double rot_abs_max_deg = 0;
  // Per used relation, in file order.
  std::vector<double> trans_errors;
  std::vector<double> rot_errors_deg;
};

// Composition helpers of the SE(2) algebra (exposed for tests and benchmarks).
Pose2 Compose(const Pose2& a, const Pose2& b);  // a (+) b
Pose2 Inverse(const Pose2& a);
double NormalizeAngle(double angle);  // to (-pi, pi]

// Looks up each relation's stamps in `trajectory` (the nearest pose within `tolerance_s`; the
// trajectory need not be sorted) and computes the metric.
RelationsResult EvaluateRelations(const std::vector<StampedPose>& trajectory,
                                  const std::vector<Relation>& relations,
                                  double tolerance_s = 1e-3);

nlohmann::json RelationsResultToJson(const RelationsResult& result);
void PrintRelationsResult(std::ostream& out, const RelationsResult& result);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_RELATIONS_METRIC_H_
