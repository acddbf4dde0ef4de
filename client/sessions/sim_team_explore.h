#ifndef WAYMARK_CLIENT_SESSIONS_SIM_TEAM_EXPLORE_H_
#define WAYMARK_CLIENT_SESSIONS_SIM_TEAM_EXPLORE_H_

// Several simulated robots exploring one shared map (issue 38; docs/exploration.md, "Several
// robots"): `waymark sim explore --robots N --map NAME`.
//
// Each robot is its own Simulation in the same world and its own laser session (the run's mode,
// ACTIVE by default) joined to the map NAME, created when missing (a map that already holds a
// trajectory is refused: its frame would not be the first robot's start). The robots start apart
// near the world's start (TeamStarts). Robot 1 defines the map frame; with `known_starts` the
// others pass CreateSessionRequest.initial_map_pose from the simulator's truth, without it they
// wait for the server's search to tie them in (their goal layers see no teammate until then).
//
// The loop is sim_explore.h's go-stop loop for all robots at once, in one simulated clock: every
// robot holds its suggestion for its duration, the robots advancing together in control steps of
// kControlStep (each robot's odometry sent after each step), then each robot in turn scans and
// waits for its answer. The other robots are discs of the body radius that every laser sees and
// every base bumps into. A robot that says DONE or STUCK stands and goes on scanning (a teammate's
// news may give it a target again); the run ends when every robot's last answer is DONE or STUCK,
// or at the duration.

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/lib/slam_client.h"
#include "client/sessions/sim_explore.h"
#include "client/sim/sim_world.h"

namespace waymark::cli {

struct TeamExploreOptions {
  ExploreOptions run;  // per robot (mode, exploration, duration, seed, ...)
  int robots = 2;
  std::string map;  // required
  bool known_starts = true;
};

struct TeamRobot {
  // Its scans: estimate_world from its map-frame pose once tied in (the map frame placed in the
  // world by robot 1's start), before that from its own frame placed at its own start;
  // final_map_world its segments, each moved by its origin in the map at the scan the robot was
  // nearest to it at.
  ExploreResult run;
  adapters::BasePose start;
  double done_time_s = -1;     // since when its answers said DONE, to the end; -1: not DONE
  double tied_in_time_s = -1;  // its first answer with a map-frame pose; -1: never
  std::vector<std::string> rooms_entered;  // the world's rooms its true position was in
};

struct TeamExploreResult {
  std::string world;
  std::string mode;
  std::string map;
  uint64_t seed = 0;
  bool known_starts = true;
  std::vector<TeamRobot> robots;
  double sim_time_s = 0;
  bool finished = false;  // every robot said DONE or STUCK
  std::vector<SceneSegment> union_map_world;  // every robot's final segments, world frame
  double completeness = 0;                    // of the union
  double completeness_visible = 0;
  double visible_wall_share = 0;
  int rooms = 0;  // annotated in the world
};

// Where the robots start: robot 1 at the world's start, the others at free places 0.8-3 m from
// it (at least 0.5 m from every wall and 0.8 m from each other, in sight of the start), facing
// the start's way; chosen from a lattice in an order drawn from `seed`. Fewer than `robots` when
// the start area has no room for them.
std::vector<adapters::BasePose> TeamStarts(const adapters::World& world, int robots, uint64_t seed);

absl::StatusOr<TeamExploreResult> RunTeamExploration(
    client::SlamClient& client, const adapters::World& world, const TeamExploreOptions& options,
    const std::function<void(double sim_time)>& on_round = {});

// summary.json of a team run: the run's figures (done_time_s: when the last robot said DONE;
// completeness of the union; loc_error_mean_m: the robots' means averaged; rooms_explored_twice:
// rooms entered by more than one robot) and `per_robot` (ExploreSummary of each, with its
// done_time_s, tied_in_time_s, start and rooms).
nlohmann::json TeamExploreSummary(const TeamExploreResult& result);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_SIM_TEAM_EXPLORE_H_
