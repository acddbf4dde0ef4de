#include "client/sessions/sim_explore.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>

#include "absl/strings/ascii.h"
#include "client/lib/exploration_progress.h"
#include "client/sessions/sim_explore_loop.h"
#include "client/sim/sim_robot.h"
#include "client/eval/eval_metrics.h"  // Percentile
#include "client/eval/exploration_metrics.h"
#include "client/robot/laser_session.h"
#include "client/render/slam_output.h"  // SegmentEndpoints

namespace waymark::cli {
namespace {

using adapters::Simulation;

// Holds one suggestion for `hold` seconds (step 3 of the protocol). Returns whether a bump cut it.
absl::StatusOr<bool> Execute(Simulation& sim, SimRobotLink& robot, const v1::SuggestedControl& control,
                             double hold) {
  if (absl::Status s = sim.base().SetVelocity(control.linear(), control.angular()); !s.ok()) {
    return s;
  }
  // Equal steps, so the hold ends exactly at its length rather than with a sliver step.
  const int steps = std::max(1, static_cast<int>(std::ceil(hold / kControlStep - 1e-9)));
  bool bumped = false;
  for (int i = 0; i < steps && !bumped; ++i) {
    sim.Advance(hold / steps);
    bumped = sim.bumped() && (control.linear() != 0 || control.angular() != 0);
    if (bumped) {
      if (absl::Status s = sim.base().Stop(); !s.ok()) return s;
    }
    if (absl::Status s = robot.SendOdometry(); !s.ok()) return s;
  }
  if (absl::Status s = sim.base().Stop(); !s.ok()) return s;
  return bumped;
}

}  // namespace

std::string ExplorationModeName(v1::ExplorationConfig::Mode mode) {
  return absl::AsciiStrToLower(v1::ExplorationConfig::Mode_Name(mode));
}

std::string RunModeName(const ExploreOptions& options) {
  if (options.mode == v1::ExplorationConfig::ACTIVE && !options.goal_layer) return "paper";
  return ExplorationModeName(options.mode);
}

std::string BehaviourName(v1::SuggestedControl::Behaviour behaviour) {
  return absl::AsciiStrToLower(v1::SuggestedControl::Behaviour_Name(behaviour));
}

absl::StatusOr<ExploreResult> RunExploration(client::SlamClient& client,
                                             const adapters::World& world,
                                             const ExploreOptions& options,
                                             const ScanCallback& on_scan) {
  Simulation sim(world, SimOptionsFor(options));

  auto session = client.CreateSession(SessionRequest(sim, world, options));
  if (!session.ok()) return session.status();
  ExploreResult result;
  result.world = world.name;
  result.mode = RunModeName(options);
  result.seed = options.seed;
  result.session_id = session->session_id();

  AnswerWaiter waiter;
  std::unique_ptr<client::SensorStream> stream = client.StreamSensorData(
      result.session_id, /*window=*/1, [&](const v1::SlamUpdate& u) { waiter.OnUpdate(u); });
  SimRobotLink robot(sim, *stream, waiter, options.answer_timeout);
  absl::StatusOr<std::unique_ptr<std::ofstream>> recording = OpenRecording(options, 1);
  if (!recording.ok()) return recording.status();
  robot.RecordTo(recording->get());

  std::optional<FrameTransform> map_to_world, odometry_to_world;
  // One scan: send it, wait, record it with the map as it is now.
  auto scan = [&]() -> absl::Status {
    auto update = robot.ScanAndWait();
    if (!update.ok()) return update.status();
    ScanRecord record;
    record.time = sim.now();
    record.true_pose = ToPose2(sim.true_pose());
    record.odometry_raw = ToPose2(sim.odometry_pose());
    if (!map_to_world) {
      map_to_world = FrameTransform::MapToWorld(record.true_pose);
      odometry_to_world = FrameTransform::OdometryToWorld(record.true_pose, record.odometry_raw);
    }
    record.odometry_world = odometry_to_world->Apply(record.odometry_raw);
    record.estimate_map = ToPose2(update->pose());
    record.estimate_world = map_to_world->Apply(record.estimate_map);
    record.loc_error_m = PositionError(record.true_pose, record.estimate_world);
    record.odometry_error_m = PositionError(record.true_pose, record.odometry_world);
    RecordAnswer(*update, &record);
    auto map = client.GetMap(result.session_id);
    if (!map.ok()) return map.status();
    result.final_map_world.clear();
    for (const v1::MapSegment& segment : map->segments()) {
      result.final_map_world.push_back(map_to_world->Apply(SegmentEndpoints(segment)));
    }
    record.completeness = Completeness(world.walls, result.final_map_world);
    result.scans.push_back(record);
    if (on_scan) on_scan(record);
    return absl::OkStatus();
  };

  // Time only ever moves forward by whole holds; the tolerance absorbs the rounding of summed
  // steps.
  constexpr double kTimeEpsilon = 1e-6;
  absl::Status status = robot.SendOdometry();
  if (status.ok()) status = scan();
  while (status.ok() && sim.now() < options.duration_s - kTimeEpsilon) {
    if (client::ExplorationEnded(result.scans.back().exploration)) {
      result.finished = true;
      break;
    }
    const v1::SuggestedControl& control = result.scans.back().suggestion;
    if (control.behaviour() == v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED) {
      status = absl::FailedPreconditionError(
          fmt::format("session is not in active or wander mode: the update to the scan at {:.2f} "
                      "s carries no suggested control",
                      sim.now()));
      break;
    }
    double hold = std::min(control.duration(), options.duration_s - sim.now());
    if (!(control.duration() > 0)) hold = std::min(kControlStep, options.duration_s - sim.now());
    auto bumped = Execute(sim, robot, control, hold);
    if (!bumped.ok()) {
      status = bumped.status();
      break;
    }
    result.early_stops += *bumped;
    if (status = waiter.Rejection(); status.ok()) status = scan();
  }

  if (!status.ok()) {
    // A stream the server ended reports why in Finish(); prefer that over the symptom seen while
    // sending. Any other failure cancels, so Finish() does not wait on a server that hangs.
    if (status.code() == absl::StatusCode::kUnavailable) {
      const absl::Status finished = stream->Finish();
      return finished.ok() ? status : finished;
    }
    stream->Cancel();
    stream->Finish().IgnoreError();
    return status;
  }
  if (absl::Status finished = stream->Finish(); !finished.ok()) return finished;
  if (absl::Status s = waiter.Rejection(); !s.ok()) return s;
  result.odometry_sent = stream->stats().odometry_sent;
  result.sim_time_s = sim.now();
  result.distance_m = sim.distance_travelled();
  result.collisions = sim.collisions();
  // Per world, so once per run (a small fraction of a second: see docs/exploration.md).
  const std::vector<adapters::WallSample> visible = adapters::VisibleWalls(world);
  result.visible_wall_share = adapters::SampleLength(visible) / std::max(1e-9, world.WallLength());
  result.completeness_visible = CompletenessOfVisible(visible, result.final_map_world);
  auto closed = client.CloseSession(result.session_id);
  if (!closed.ok()) return closed.status();
  return result;
}

nlohmann::json ExploreSummary(const ExploreResult& result) {
  std::vector<double> errors, planning_ms;
  double cov_sum = 0;
  int executed = 0, wall_following = 0;
  for (size_t i = 0; i < result.scans.size(); ++i) {
    const ScanRecord& r = result.scans[i];
    errors.push_back(r.loc_error_m);
    cov_sum += r.cov_trace_mean;
    if (r.suggestion.behaviour() != v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED) {
      planning_ms.push_back(r.suggestion.planning_ms());
    }
    // The last scan's suggestion is never driven: the share is over the suggestions executed.
    if (i + 1 < result.scans.size()) {
      ++executed;
      wall_following += r.suggestion.behaviour() == v1::SuggestedControl::WALL_FOLLOWING;
    }
  }
  const bool any = !result.scans.empty();
  const ScanRecord last = any ? result.scans.back() : ScanRecord{};
  double error_sum = 0, error_max = 0;
  for (double e : errors) {
    error_sum += e;
    error_max = std::max(error_max, e);
  }
  const double n = std::max<double>(1, result.scans.size());
  // Completeness at a time: the last scan at or before it (the final one when the run ended
  // earlier, at DONE: nothing more would be mapped).
  auto completeness_at = [&](double t) {
    double c = 0;
    for (const ScanRecord& r : result.scans) {
      if (r.time > t + 1e-6) break;
      c = r.completeness;
    }
    return c;
  };
  double time_to_95 = -1;
  for (const ScanRecord& r : result.scans) {
    if (r.completeness >= 0.95) {
      time_to_95 = r.time;
      break;
    }
  }
  const v1::ExplorationProgress& progress = last.exploration;
  const bool has_state = progress.state() != v1::ExplorationProgress::STATE_UNSPECIFIED;
  const std::string state = client::ExplorationStateName(progress);
  const double done_time =
      progress.state() == v1::ExplorationProgress::DONE ? last.time : -1.0;
  return {
      {"world", result.world},
      {"mode", result.mode},
      {"seed", result.seed},
      {"session_id", result.session_id},
      {"sim_time_s", result.sim_time_s},
      {"scans", result.scans.size()},
      {"segments", last.segments},
      {"completeness", last.completeness},
      {"completeness_visible", result.completeness_visible},
      {"visible_wall_share", result.visible_wall_share},
      {"loc_error_mean_m", error_sum / n},
      {"loc_error_final_m", last.loc_error_m},
      {"loc_error_max_m", error_max},
      {"odometry_error_final_m", last.odometry_error_m},
      {"cov_trace_mean", cov_sum / n},
      {"cov_trace_final", last.cov_trace_mean},
      {"collisions", result.collisions},
      {"early_stops", result.early_stops},
      {"distance_m", result.distance_m},
      {"wall_following_share", executed > 0 ? static_cast<double>(wall_following) / executed : 0},
      {"planning_ms_p50", Percentile(planning_ms, 50).value_or(0)},
      {"planning_ms_p99", Percentile(planning_ms, 99).value_or(0)},
      {"completeness_300s", completeness_at(300)},
      {"completeness_600s", completeness_at(600)},
      {"completeness_1200s", completeness_at(1200)},
      {"time_to_95_s", time_to_95},
      {"done_time_s", done_time},
      {"final_state", state},
      {"final_reason", progress.reason()},
      {"open_boundary_final", has_state ? progress.open_boundary() : -1.0},
      {"targets_given_up", progress.given_up()},
      {"known_area_m2", progress.known_area()},
      {"odometry_sent", result.odometry_sent},
  };
}

}  // namespace waymark::cli
