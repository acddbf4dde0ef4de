#include "client/eval/relations_metric.h"
#include "client/common/numeric_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

// Index of the pose nearest to `t` within the tolerance in the sorted stamps, or -1.
int Nearest(const std::vector<double>& stamps, double t, double tolerance) {
  auto it = std::lower_bound(stamps.begin(), stamps.end(), t);
  int best = -1;
  double best_gap = tolerance;
  for (auto candidate : {it, it == stamps.begin() ? stamps.end() : std::prev(it)}) {
    if (candidate == stamps.end()) continue;
    const double gap = std::abs(*candidate - t);
    if (gap <= best_gap) {
      best_gap = gap;
      best = static_cast<int>(candidate - stamps.begin());
    }
  }
  return best;
}

}  // namespace

double NormalizeAngle(double angle) {
  angle = std::fmod(angle, 2 * kPi);
  if (angle <= -kPi) angle += 2 * kPi;
  if (angle > kPi) angle -= 2 * kPi;
  return angle;
}

Pose2 Compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, NormalizeAngle(a.theta + b.theta)};
}

Pose2 Inverse(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, NormalizeAngle(-a.theta)};
}

MeanStd ComputeMeanStd(const std::vector<double>& values) {
  MeanStd result;
  if (values.empty()) return result;
  double sum = 0;
  for (double v : values) sum += v;
  result.mean = sum / values.size();
  double squares = 0;
  for (double v : values) squares += (v - result.mean) * (v - result.mean);
  result.std = std::sqrt(squares / values.size());
  return result;
}

absl::StatusOr<std::vector<Relation>> ParseRelations(const std::string& text) {
  absl::StatusOr<std::vector<NumericRow>> rows =
      ParseNumericRows(text, 8, "t1 t2 x y z roll pitch yaw", " \t");
  if (!rows.ok()) return rows.status();
  std::vector<Relation> relations;
  relations.reserve(rows->size());
  for (const NumericRow& row : *rows) {
    const std::vector<double>& v = row.values;
    relations.push_back({v[0], v[1], {v[2], v[3], v[7]}});
  }
  return relations;
}

absl::StatusOr<std::vector<Relation>> ReadRelationsFile(const std::string& path) {
  return ReadAndParse(path, ParseRelations);
}

RelationsResult EvaluateRelations(const std::vector<StampedPose>& trajectory,
                                  const std::vector<Relation>& relations, double tolerance_s) {
  std::vector<StampedPose> sorted = trajectory;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  std::vector<double> stamps;
  stamps.reserve(sorted.size());
  for (const StampedPose& p : sorted) stamps.push_back(p.stamp);

  RelationsResult result;
  result.relations = static_cast<int>(relations.size());
  std::vector<double> trans_sq, rot_sq;
  for (const Relation& relation : relations) {
    const int i1 = Nearest(stamps, relation.t1, tolerance_s);
    const int i2 = Nearest(stamps, relation.t2, tolerance_s);
    if (i1 < 0) {
      ++result.missing_t1;
      continue;
    }
    if (i2 < 0) {
      ++result.missing_t2;
      continue;
    }
    const Pose2 estimated = Compose(Inverse(sorted[i1].pose), sorted[i2].pose);
    const Pose2 error = Compose(Inverse(relation.delta), estimated);
    const double trans = std::hypot(error.x, error.y);
    const double rot = std::abs(NormalizeAngle(error.theta)) * kDeg;
    result.trans_errors.push_back(trans);
    result.rot_errors_deg.push_back(rot);
    trans_sq.push_back(trans * trans);
    rot_sq.push_back(rot * rot);
    result.trans_abs_max = std::max(result.trans_abs_max, trans);
    result.rot_abs_max_deg = std::max(result.rot_abs_max_deg, rot);
  }
  result.relations_used = static_cast<int>(result.trans_errors.size());
  result.trans_abs = ComputeMeanStd(result.trans_errors);
  result.rot_abs_deg = ComputeMeanStd(result.rot_errors_deg);
  result.trans_sq = ComputeMeanStd(trans_sq);
  result.rot_sq_deg2 = ComputeMeanStd(rot_sq);
  return result;
}

nlohmann::json RelationsResultToJson(const RelationsResult& r) {
  return {
      {"relations", r.relations},
      {"relations_used", r.relations_used},
      {"relations_missing_pose", r.relations - r.relations_used},
      {"missing_t1", r.missing_t1},
      {"missing_t2", r.missing_t2},
      {"trans_abs_mean", r.trans_abs.mean},
      {"trans_abs_std", r.trans_abs.std},
      {"trans_abs_max", r.trans_abs_max},
      {"trans_sq_mean", r.trans_sq.mean},
      {"trans_sq_std", r.trans_sq.std},
      {"rot_abs_mean_deg", r.rot_abs_deg.mean},
      {"rot_abs_std_deg", r.rot_abs_deg.std},
      {"rot_abs_max_deg", r.rot_abs_max_deg},
      {"rot_sq_mean_deg2", r.rot_sq_deg2.mean},
      {"rot_sq_std_deg2", r.rot_sq_deg2.std},
  };
}

void PrintRelationsResult(std::ostream& out, const RelationsResult& r) {
  out << fmt::format("relations:            {} ({} used, {} without a pose: {} at t1, {} at t2)\n",
                     r.relations, r.relations_used, r.relations - r.relations_used, r.missing_t1,
                     r.missing_t2);
  out << fmt::format("translational abs:    {:.4f} +- {:.4f} m (max {:.4f})\n", r.trans_abs.mean,
                     r.trans_abs.std, r.trans_abs_max);
  out << fmt::format("translational sq:     {:.4f} +- {:.4f} m^2\n", r.trans_sq.mean,
                     r.trans_sq.std);
  out << fmt::format("rotational abs:       {:.3f} +- {:.3f} deg (max {:.3f})\n",
                     r.rot_abs_deg.mean, r.rot_abs_deg.std, r.rot_abs_max_deg);
  out << fmt::format("rotational sq:        {:.3f} +- {:.3f} deg^2\n", r.rot_sq_deg2.mean,
                     r.rot_sq_deg2.std);
}

}  // namespace waymark::cli
