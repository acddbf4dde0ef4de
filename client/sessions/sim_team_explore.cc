#include "client/sessions/sim_team_explore.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>

#include "client/eval/exploration_metrics.h"
#include "client/eval/relations_metric.h"  // Inverse
#include "client/lib/exploration_progress.h"
#include "client/render/slam_output.h"  // SegmentEndpoints
#include "client/sessions/sim_explore_loop.h"
#include "client/sim/sim_geometry.h"
#include "client/sim/sim_reach.h"
#include "client/sim/sim_robot.h"

namespace waymark::cli {
namespace {

using adapters::BasePose;
using adapters::Simulation;

// One robot of the team while the run goes.
struct Member {
  std::unique_ptr<Simulation> sim;
  std::string session_id;
  std::unique_ptr<AnswerWaiter> waiter;
  std::unique_ptr<client::SensorStream> stream;
  std::unique_ptr<SimRobotLink> link;
  std::unique_ptr<std::ofstream> recording;  // ExploreOptions::record_dir; null: none
  std::optional<FrameTransform> own_to_world, odometry_to_world;
  std::optional<Pose2> origin;  // its session frame in the map frame (from its last answer)
  // Per scan: where it was in its session frame, and its origin in the map then (tied in only).
  std::vector<std::pair<Pose2, Pose2>> origins;
  std::set<std::string> rooms;
  TeamRobot out;
};

// The other robots' bodies, for robot `self`'s laser and base.
void PlaceOthers(std::vector<Member>& team, size_t self) {
  std::vector<adapters::OtherBody> bodies;
  for (size_t k = 0; k < team.size(); ++k) {
    if (k == self) continue;
    const BasePose p = team[k].sim->true_pose();
    bodies.push_back({p.x, p.y, team[k].sim->options().body_radius});
  }
  team[self].sim->SetOtherBodies(std::move(bodies));
}

void MarkRooms(const adapters::World& world, Member& m) {
  const BasePose p = m.sim->true_pose();
  for (const adapters::Room& room : world.rooms) {
    if (room.Contains(p.x, p.y)) m.rooms.insert(room.name);
  }
}

}  // namespace

std::vector<BasePose> TeamStarts(const adapters::World& world, int robots, uint64_t seed) {
  std::vector<BasePose> starts = {world.start};
  constexpr double kLattice = 0.4, kMinWall = 0.5, kMinApart = 0.8, kMaxReach = 3.0;
  std::vector<BasePose> candidates;
  for (double dy = -kMaxReach; dy <= kMaxReach + 1e-9; dy += kLattice) {
    for (double dx = -kMaxReach; dx <= kMaxReach + 1e-9; dx += kLattice) {
      const double d = std::hypot(dx, dy);
      if (d < kMinApart || d > kMaxReach) continue;
      const BasePose p{world.start.x + dx, world.start.y + dy, world.start.theta};
      if (adapters::geometry::Clearance(world.walls, p.x, p.y) < kMinWall) continue;
      const double hit = adapters::geometry::CastRay(world.walls, world.start.x, world.start.y,
                                                     dx / d, dy / d);
      if (hit < d + kMinWall) continue;  // not in sight of the start
      candidates.push_back(p);
    }
  }
  std::mt19937_64 rng(seed);
  // Fisher-Yates with the generator's raw numbers: the same order on every standard library.
  for (size_t i = candidates.size(); i > 1; --i) std::swap(candidates[i - 1], candidates[rng() % i]);
  for (const BasePose& c : candidates) {
    if (static_cast<int>(starts.size()) >= robots) break;
    bool apart = true;
    for (const BasePose& s : starts) apart = apart && std::hypot(c.x - s.x, c.y - s.y) >= kMinApart;
    if (apart) starts.push_back(c);
  }
  return starts;
}

absl::StatusOr<TeamExploreResult> RunTeamExploration(
    client::SlamClient& client, const adapters::World& world, const TeamExploreOptions& options,
    const std::function<void(double)>& on_round) {
  if (options.robots < 1) return absl::InvalidArgumentError("--robots must be at least 1");
  if (options.map.empty()) return absl::InvalidArgumentError("several robots need --map NAME");
  // The map: made here when missing; one that already holds trajectories has its frame elsewhere.
  absl::StatusOr<v1::Map> map = client.GetMapInfo(options.map);
  if (!map.ok() && map.status().code() == absl::StatusCode::kNotFound) {
    map = client.CreateMap(options.map);
  }
  if (!map.ok()) return map.status();
  if (map->trajectories_size() > 0) {
    return absl::FailedPreconditionError(fmt::format(
        "map \"{}\" already holds {} trajectories: explore into a new map (its frame is the first "
        "robot's start)",
        options.map, map->trajectories_size()));
  }
  const std::vector<BasePose> starts = TeamStarts(world, options.robots, options.run.seed);
  if (static_cast<int>(starts.size()) < options.robots) {
    return absl::InvalidArgumentError(fmt::format(
        "no room for {} robots near the start of {} ({} fit)", options.robots, world.name,
        starts.size()));
  }
  TeamExploreResult result;
  result.world = world.name;
  result.mode = RunModeName(options.run);
  result.map = options.map;
  result.seed = options.run.seed;
  result.known_starts = options.known_starts;
  result.rooms = static_cast<int>(world.rooms.size());
  // The map frame is robot 1's session frame: its start.
  const FrameTransform map_to_world = FrameTransform::MapToWorld(ToPose2(starts[0]));

  std::vector<Member> team(options.robots);
  auto cancel_all = [&] {
    for (Member& m : team) {
      if (m.stream) {
        m.stream->Cancel();
        m.stream->Finish().IgnoreError();
      }
    }
  };
  for (int k = 0; k < options.robots; ++k) {
    Member& m = team[k];
    adapters::SimOptions sim_options = SimOptionsFor(options.run);
    // Robot 1 draws the single robot's numbers; the others their own.
    sim_options.seed = options.run.seed + 7919 * static_cast<uint64_t>(k);
    sim_options.start = starts[k];
    m.sim = std::make_unique<Simulation>(world, sim_options);
    ExploreOptions run = options.run;
    if (run.session_name.empty()) {
      run.session_name = fmt::format("sim explore {} {} s{} robot {}/{}", world.name,
                                     RunModeName(options.run), options.run.seed, k + 1,
                                     options.robots);
    }
    v1::CreateSessionRequest request =
        SessionRequest(*m.sim, world, run, fmt::format("sim-{}", k + 1));
    request.set_map(options.map);
    if (k > 0 && options.known_starts) {
      const Pose2 at = FrameTransform{Inverse(ToPose2(starts[0]))}.Apply(ToPose2(starts[k]));
      v1::Pose2D* pose = request.mutable_initial_map_pose();
      pose->set_x(at.x);
      pose->set_y(at.y);
      pose->set_theta(at.theta);
    }
    auto session = client.CreateSession(request);
    if (!session.ok()) {
      cancel_all();
      return session.status();
    }
    m.session_id = session->session_id();
    m.waiter = std::make_unique<AnswerWaiter>();
    AnswerWaiter* waiter = m.waiter.get();
    m.stream = client.StreamSensorData(m.session_id, /*window=*/1,
                                       [waiter](const v1::SlamUpdate& u) { waiter->OnUpdate(u); });
    m.link = std::make_unique<SimRobotLink>(*m.sim, *m.stream, *m.waiter,
                                            options.run.answer_timeout);
    absl::StatusOr<std::unique_ptr<std::ofstream>> recording =
        OpenRecording(options.run, static_cast<int>(k) + 1);
    if (!recording.ok()) {
      cancel_all();
      return recording.status();
    }
    m.recording = *std::move(recording);
    m.link->RecordTo(m.recording.get());
    m.out.start = starts[k];
    m.out.run.world = world.name;
    m.out.run.mode = result.mode;
    m.out.run.seed = options.run.seed;
    m.out.run.session_id = m.session_id;
  }

  // One robot's scan: send it, wait, record it with its map as it is now.
  auto scan = [&](size_t k) -> absl::Status {
    Member& m = team[k];
    PlaceOthers(team, k);
    auto update = m.link->ScanAndWait();
    if (!update.ok()) return update.status();
    ScanRecord record;
    const Simulation& sim = *m.sim;
    record.time = sim.now();
    record.true_pose = ToPose2(sim.true_pose());
    record.odometry_raw = ToPose2(sim.odometry_pose());
    if (!m.own_to_world) {
      m.own_to_world = FrameTransform::MapToWorld(record.true_pose);
      m.odometry_to_world = FrameTransform::OdometryToWorld(record.true_pose, record.odometry_raw);
    }
    record.odometry_world = m.odometry_to_world->Apply(record.odometry_raw);
    record.estimate_map = ToPose2(update->pose());
    if (update->map_pose().tied_in()) {
      const Pose2 in_map = ToPose2(update->map_pose().pose());
      record.estimate_world = map_to_world.Apply(in_map);
      m.origin = FrameTransform{in_map}.Apply(Inverse(record.estimate_map));
      m.origins.emplace_back(record.estimate_map, *m.origin);
      if (m.out.tied_in_time_s < 0) m.out.tied_in_time_s = record.time;
    } else {
      record.estimate_world = m.own_to_world->Apply(record.estimate_map);
    }
    record.loc_error_m = PositionError(record.true_pose, record.estimate_world);
    record.odometry_error_m = PositionError(record.true_pose, record.odometry_world);
    RecordAnswer(*update, &record);
    auto segments = client.GetMap(m.session_id);
    if (!segments.ok()) return segments.status();
    // Its segments in the world: through its origin in the map once tied in. The origin is
    // piecewise (the follow, trajectory_follow.h), and the map frame's grid moves each scan by the
    // origin at its stamp; a segment carries no scan, so it takes the origin of the scan the robot
    // was nearest to it at (before its tie: its own frame, placed at its true start).
    m.out.run.final_map_world.clear();
    for (const v1::MapSegment& segment : segments->segments()) {
      const SceneSegment local = SegmentEndpoints(segment);
      FrameTransform to_world = *m.own_to_world;
      if (!m.origins.empty()) {
        const double mx = 0.5 * (local.a.x + local.b.x), my = 0.5 * (local.a.y + local.b.y);
        size_t nearest = 0;
        double best = std::numeric_limits<double>::infinity();
        for (size_t i = 0; i < m.origins.size(); ++i) {
          const double d = std::hypot(m.origins[i].first.x - mx, m.origins[i].first.y - my);
          if (d < best) {
            best = d;
            nearest = i;
          }
        }
        to_world = FrameTransform{map_to_world.Apply(m.origins[nearest].second)};
      }
      m.out.run.final_map_world.push_back(to_world.Apply(local));
    }
    record.completeness = Completeness(world.walls, m.out.run.final_map_world);
    if (record.exploration.state() == v1::ExplorationProgress::DONE) {
      if (m.out.done_time_s < 0) m.out.done_time_s = record.time;
    } else {
      m.out.done_time_s = -1;
    }
    m.out.run.scans.push_back(record);
    return absl::OkStatus();
  };

  constexpr double kTimeEpsilon = 1e-6;
  const double duration = options.run.duration_s;
  absl::Status status;
  for (size_t k = 0; k < team.size() && status.ok(); ++k) {
    MarkRooms(world, team[k]);
    status = team[k].link->SendOdometry();
  }
  for (size_t k = 0; k < team.size() && status.ok(); ++k) status = scan(k);
  double now = 0;
  while (status.ok() && now < duration - kTimeEpsilon) {
    bool all_ended = true;
    for (const Member& m : team) {
      all_ended = all_ended && client::ExplorationEnded(m.out.run.scans.back().exploration);
    }
    if (all_ended) {
      result.finished = true;
      break;
    }
    // Every robot's hold (step 3 of sim_explore.h's protocol); the round lasts the longest.
    std::vector<double> holds;
    double round = 0;
    for (Member& m : team) {
      const v1::SuggestedControl& control = m.out.run.scans.back().suggestion;
      if (control.behaviour() == v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED) {
        status = absl::FailedPreconditionError(fmt::format(
            "session {} is not in active or wander mode: its answer at {:.2f} s carries no "
            "suggested control",
            m.session_id, now));
        break;
      }
      double hold = std::min(control.duration(), duration - now);
      if (!(control.duration() > 0)) hold = std::min(kControlStep, duration - now);
      holds.push_back(hold);
      round = std::max(round, hold);
      status = m.sim->base().SetVelocity(control.linear(), control.angular());
      if (!status.ok()) break;
    }
    if (!status.ok()) break;
    const int steps = std::max(1, static_cast<int>(std::ceil(round / kControlStep - 1e-9)));
    std::vector<bool> bumped(team.size(), false);
    for (int i = 0; i < steps && status.ok(); ++i) {
      for (size_t k = 0; k < team.size() && status.ok(); ++k) {
        Member& m = team[k];
        const v1::SuggestedControl& control = m.out.run.scans.back().suggestion;
        // Past its own hold, or bumped: the robot stands while the others finish theirs.
        if (bumped[k] || (i + 0.5) * round / steps > holds[k]) status = m.sim->base().Stop();
        if (!status.ok()) break;
        PlaceOthers(team, k);
        m.sim->Advance(round / steps);
        if (!bumped[k] && m.sim->bumped() && (control.linear() != 0 || control.angular() != 0)) {
          bumped[k] = true;
          ++m.out.run.early_stops;
          status = m.sim->base().Stop();
        }
        MarkRooms(world, m);
        if (status.ok()) status = m.link->SendOdometry();
      }
    }
    now = team[0].sim->now();
    for (size_t k = 0; k < team.size() && status.ok(); ++k) {
      if (status = team[k].sim->base().Stop(); status.ok()) status = team[k].waiter->Rejection();
      if (status.ok()) status = scan(k);
    }
    if (on_round) on_round(now);
  }
  if (!status.ok()) {
    cancel_all();
    return status;
  }
  for (Member& m : team) {
    if (absl::Status finished = m.stream->Finish(); !finished.ok()) return finished;
    if (absl::Status s = m.waiter->Rejection(); !s.ok()) return s;
  }
  const std::vector<adapters::WallSample> visible = adapters::VisibleWalls(world);
  result.visible_wall_share = adapters::SampleLength(visible) / std::max(1e-9, world.WallLength());
  result.sim_time_s = now;
  for (Member& m : team) {
    ExploreResult& run = m.out.run;
    run.odometry_sent = m.stream->stats().odometry_sent;
    run.sim_time_s = m.sim->now();
    run.distance_m = m.sim->distance_travelled();
    run.collisions = m.sim->collisions();
    run.finished = client::ExplorationEnded(run.scans.back().exploration);
    run.visible_wall_share = result.visible_wall_share;
    run.completeness_visible = CompletenessOfVisible(visible, run.final_map_world);
    m.out.rooms_entered.assign(m.rooms.begin(), m.rooms.end());
    result.union_map_world.insert(result.union_map_world.end(), run.final_map_world.begin(),
                                  run.final_map_world.end());
    auto closed = client.CloseSession(m.session_id);
    if (!closed.ok()) return closed.status();
    result.robots.push_back(std::move(m.out));
  }
  result.completeness = Completeness(world.walls, result.union_map_world);
  result.completeness_visible = CompletenessOfVisible(visible, result.union_map_world);
  return result;
}

nlohmann::json TeamExploreSummary(const TeamExploreResult& result) {
  nlohmann::json per_robot = nlohmann::json::array();
  std::map<std::string, int> entered;  // room -> robots
  double done_time = result.robots.empty() ? -1 : 0;
  double loc_error = 0, distance = 0;
  int collisions = 0;
  size_t decisions = 0;
  for (size_t k = 0; k < result.robots.size(); ++k) {
    const TeamRobot& r = result.robots[k];
    nlohmann::json s = ExploreSummary(r.run);
    s["robot"] = k + 1;
    s["done_time_s"] = r.done_time_s;
    s["tied_in_time_s"] = r.tied_in_time_s;
    s["start"] = {r.start.x, r.start.y, r.start.theta};
    s["rooms_entered"] = r.rooms_entered;
    for (const std::string& room : r.rooms_entered) ++entered[room];
    done_time = r.done_time_s < 0 || done_time < 0 ? -1 : std::max(done_time, r.done_time_s);
    loc_error += s["loc_error_mean_m"].get<double>();
    distance += r.run.distance_m;
    collisions += r.run.collisions;
    decisions += r.run.scans.size();
    per_robot.push_back(std::move(s));
  }
  const double n = std::max<double>(1, result.robots.size());
  int twice = 0;
  std::vector<std::string> twice_names;
  for (const auto& [room, robots] : entered) {
    if (robots > 1) {
      ++twice;
      twice_names.push_back(room);
    }
  }
  return {
      {"world", result.world},
      {"mode", result.mode},
      {"seed", result.seed},
      {"map", result.map},
      {"robots", result.robots.size()},
      {"known_starts", result.known_starts},
      {"sim_time_s", result.sim_time_s},
      {"finished", result.finished},
      {"done_time_s", done_time},
      {"completeness", result.completeness},
      {"completeness_visible", result.completeness_visible},
      {"visible_wall_share", result.visible_wall_share},
      {"loc_error_mean_m", loc_error / n},
      {"distance_m", distance},
      {"collisions", collisions},
      {"scans_per_robot", decisions / n},
      {"rooms", result.rooms},
      {"rooms_entered", entered.size()},
      {"rooms_explored_twice", twice},
      {"rooms_explored_twice_names", twice_names},
      {"per_robot", per_robot},
  };
}

}  // namespace waymark::cli
