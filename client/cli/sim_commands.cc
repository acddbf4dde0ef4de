// `waymark sim ...`: the robot simulator against a SLAM server. `sim explore` runs the closed
// exploration loop (sim_explore.h) and writes its outputs here; `sim worlds` lists the built-in
// worlds.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <system_error>

#include <google/protobuf/text_format.h>

#include "absl/strings/ascii.h"
#include "client/lib/exploration_progress.h"
#include "client/sim/sim_reach.h"
#include "client/sim/sim_world.h"
#include "client/cli/command.h"
#include "client/render/map_render.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/sessions/sim_explore.h"
#include "client/sessions/sim_team_explore.h"
#include "client/render/timeline_plot.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;

struct ExploreArgs {
  std::string world;
  std::string mode = "active";
  double duration_s = 1800;
  uint64_t seed = 1;
  bool half_degree = false;
  double odometry_error = 1.0;
  std::string out_dir;  // default ./out/sim-<world>-<mode>-s<seed>
  std::string exploration;  // ExplorationConfig fields, protobuf text format
  // Several robots in one map (sim_team_explore.h).
  int robots = 1;
  std::string map;
  bool known_starts = true;
  std::string record;  // ExploreOptions::record_dir
};

// A file-loaded world without a `name` line is called after its file.
std::string WorldName(const adapters::World& world, const std::string& argument) {
  if (!world.name.empty()) return world.name;
  const std::string stem = fs::path(argument).stem().string();
  return stem.empty() ? "world" : stem;
}

std::vector<StampedPose> Track(const ExploreResult& result, Pose2 ScanRecord::*pose) {
  std::vector<StampedPose> track;
  for (const ScanRecord& r : result.scans) track.push_back({r.time, r.*pose});
  return track;
}

ScenePolyline Path(const ExploreResult& result, Pose2 ScanRecord::*pose, Rgb color,
                   const std::string& label) {
  ScenePolyline line;
  line.color = color;
  line.width_px = 1.5;
  line.label = label;
  line.mark_ends = true;
  for (const ScanRecord& r : result.scans) line.points.push_back({(r.*pose).x, (r.*pose).y});
  return line;
}

// Everything in the world frame: the true walls underneath in light grey, the mapped segments,
// the true, estimated and odometry-only paths (each with start and end markers), and the robot's
// last estimated pose as the current pose.
MapScene ExploreScene(const ExploreResult& result, const adapters::World& world) {
  MapScene scene;
  scene.title = fmt::format("{} ({}, seed {}): {:.0f} s, completeness {:.0f}%", result.world,
                            result.mode, result.seed, result.sim_time_s,
                            result.scans.empty() ? 0.0 : 100 * result.scans.back().completeness);
  for (const adapters::Wall& wall : world.walls) {
    ScenePolyline line;
    line.points = {{wall.x1, wall.y1}, {wall.x2, wall.y2}};
    line.color = {200, 200, 200};
    line.width_px = 5;
    line.label = scene.references.empty() ? "true walls" : "";  // one legend row for all walls
    scene.references.push_back(std::move(line));
  }
  scene.references.push_back(
      Path(result, &ScanRecord::odometry_world, {150, 150, 150}, "odometry only"));
  scene.segments = result.final_map_world;
  // The estimate wide underneath, the truth thin on top: where they agree both stay visible.
  ScenePolyline estimate =
      Path(result, &ScanRecord::estimate_world, {230, 80, 80}, "estimated trajectory");
  estimate.width_px = 3;
  if (!result.scans.empty()) {
    const Pose2& last = result.scans.back().estimate_world;
    scene.current_pose =
        ScenePose{{last.x, last.y}, last.theta, estimate.color, "current pose (estimate)"};
  }
  scene.polylines.push_back(std::move(estimate));
  scene.polylines.push_back(Path(result, &ScanRecord::true_pose, {0, 0, 0}, "true trajectory"));
  return scene;
}

TimelinePlot ExploreTimeline(const ExploreResult& result) {
  auto series = [&](const std::string& label, Rgb color, double ScanRecord::*value) {
    PlotSeries s{label, color, {}};
    for (const ScanRecord& r : result.scans) s.points.push_back({r.time, r.*value});
    return s;
  };
  TimelinePlot plot;
  plot.title = fmt::format("{} ({}, seed {})", result.world, result.mode, result.seed);
  plot.x_label = "simulated time (s)";
  plot.panels.push_back({"localisation error (m)",
                         {series("SLAM estimate", {220, 30, 30}, &ScanRecord::loc_error_m),
                          series("odometry only", {150, 150, 150}, &ScanRecord::odometry_error_m)},
                         std::nullopt,
                         std::nullopt});
  plot.panels.push_back(
      {"mean covariance trace",
       {series("robot and active segments", {20, 70, 190}, &ScanRecord::cov_trace_mean)},
       std::nullopt,
       std::nullopt});
  plot.panels.push_back(
      {"map completeness (share of true wall length)",
       {series("within 0.1 m of a segment", {30, 150, 60}, &ScanRecord::completeness)},
       0.0,
       1.0});
  return plot;
}

absl::Status WriteTimelineCsv(const fs::path& path, const ExploreResult& result) {
  std::ofstream out(path);
  out << "t_s,true_x,true_y,true_theta,est_x,est_y,est_theta,odom_x,odom_y,odom_theta,"
         "loc_error_m,odometry_error_m,robot_cov_trace,cov_trace_mean,segments,completeness,"
         "behaviour,linear,angular,duration,j,j1,j21,j22,planning_ms,state,target_kind,target_x,"
         "target_y,path_length,open_boundary,loop_closures\n";
  for (const ScanRecord& r : result.scans) {
    const v1::SuggestedControl& c = r.suggestion;
    out << fmt::format(
        "{:.3f},{:.4f},{:.4f},{:.5f},{:.4f},{:.4f},{:.5f},{:.4f},{:.4f},{:.5f},{:.4f},{:.4f},{:.6g}"
        ","
        "{:.6g},{},{:.4f},{},{:.4f},{:.4f},{:.3f},{:.6g},{:.6g},{:.6g},{:.6g},{:.3f},{},{},{:.3f},"
        "{:.3f},{:.3f},{:.4f},{}\n",
        r.time, r.true_pose.x, r.true_pose.y, r.true_pose.theta, r.estimate_world.x,
        r.estimate_world.y, r.estimate_world.theta, r.odometry_world.x, r.odometry_world.y,
        r.odometry_world.theta, r.loc_error_m, r.odometry_error_m, r.robot_cov_trace,
        r.cov_trace_mean, r.segments, r.completeness, BehaviourName(c.behaviour()), c.linear(),
        c.angular(), c.duration(), c.j(), c.j1(), c.j21(), c.j22(), c.planning_ms(),
        client::ExplorationStateName(r.exploration),
        absl::AsciiStrToLower(v1::ExplorationProgress::TargetKind_Name(r.exploration.target_kind())),
        r.exploration.target().x(), r.exploration.target().y(), r.exploration.path_length(),
        r.exploration.open_boundary(), r.loop_closures);
  }
  out.close();
  if (!out) return absl::PermissionDeniedError("cannot write '" + path.string() + "'");
  return absl::OkStatus();
}

absl::Status WriteExploreFiles(const fs::path& dir, const ExploreResult& result,
                               const adapters::World& world, const nlohmann::json& summary) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    return absl::PermissionDeniedError("cannot create '" + dir.string() + "': " + ec.message());
  const std::pair<const char*, Pose2 ScanRecord::*> tracks[] = {
      {"trajectory_true.txt", &ScanRecord::true_pose},
      {"trajectory_estimated.txt", &ScanRecord::estimate_world},
      {"trajectory_odometry.txt", &ScanRecord::odometry_world},
  };
  for (const auto& [name, pose] : tracks) {
    if (absl::Status s = WriteTumFile(dir / name, Track(result, pose)); !s.ok()) return s;
  }
  if (absl::Status s =
          WriteMapPictures(ExploreScene(result, world), dir / "map.svg", dir / "map.png");
      !s.ok()) {
    return s;
  }
  if (absl::Status s = WriteTimelineCsv(dir / "timeline.csv", result); !s.ok()) return s;
  if (absl::Status s = WriteTimelinePictures(ExploreTimeline(result), dir / "timeline.svg",
                                             dir / "timeline.png");
      !s.ok()) {
    return s;
  }
  std::ofstream out(dir / "summary.json");
  out << summary.dump(2) << "\n";
  out.close();
  if (!out) return absl::PermissionDeniedError("cannot write summary.json in " + dir.string());
  return absl::OkStatus();
}

void PrintSummary(std::ostream& out, const nlohmann::json& s) {
  auto number = [&](const char* key, int decimals) {
    return FormatNumber(s[key].get<double>(), decimals);
  };
  Table table({{"metric"}, {"value", true}});
  table.AddRow({"world / mode / seed",
                fmt::format("{} / {} / {}", s["world"].get<std::string>(),
                            s["mode"].get<std::string>(), s["seed"].get<uint64_t>())});
  table.AddRow({"simulated time (s)", number("sim_time_s", 1)});
  table.AddRow({"scans", std::to_string(s["scans"].get<int>())});
  table.AddRow({"distance (m)", number("distance_m", 2)});
  table.AddRow({"segments", std::to_string(s["segments"].get<int>())});
  table.AddRow({"completeness", FormatPercent(s["completeness"].get<double>())});
  table.AddRow({"completeness of the visible walls",
                FormatPercent(s["completeness_visible"].get<double>())});
  table.AddRow({"visible wall share", FormatPercent(s["visible_wall_share"].get<double>())});
  table.AddRow({"localisation error mean (m)", number("loc_error_mean_m", 3)});
  table.AddRow({"localisation error final (m)", number("loc_error_final_m", 3)});
  table.AddRow({"odometry-only error final (m)", number("odometry_error_final_m", 3)});
  table.AddRow(
      {"mean covariance trace (run mean)", FormatNumber(s["cov_trace_mean"].get<double>(), 5)});
  table.AddRow({"collisions", std::to_string(s["collisions"].get<int>())});
  table.AddRow({"wall following share", FormatPercent(s["wall_following_share"].get<double>())});
  table.AddRow({"planning p50 / p99 (ms)", fmt::format("{} / {}", number("planning_ms_p50", 2),
                                                          number("planning_ms_p99", 2))});
  const std::string state = s["final_state"].get<std::string>();
  if (state != "-") {
    table.AddRow({"exploration", state});
    table.AddRow({"open boundary at the end", FormatPercent(s["open_boundary_final"].get<double>())});
  }
  table.Print(out);
  // The reason is a sentence: below the table rather than stretching its column.
  if (state != "-" && !s["final_reason"].get<std::string>().empty()) {
    out << state << ": " << s["final_reason"].get<std::string>() << "\n";
  }
  out << "wrote " << s["out_dir"].get<std::string>()
      << "/trajectory_{true,estimated,odometry}.txt, map.svg, map.png, timeline.csv, "
         "timeline.svg, timeline.png, summary.json\n";
}

int RunTeamExplore(CommandContext& context, const ExploreArgs& args, adapters::World world,
                   ExploreOptions options);

int RunExplore(CommandContext& context, const ExploreArgs& args) {
  auto world = adapters::LoadWorld(args.world);
  if (!world.ok()) return ReportError(context, world.status(), args.world);
  world->name = WorldName(*world, args.world);
  ExploreOptions options;
  options.mode = args.mode == "wander"     ? v1::ExplorationConfig::WANDER
                 : args.mode == "frontier" ? v1::ExplorationConfig::FRONTIER
                                           : v1::ExplorationConfig::ACTIVE;
  options.goal_layer = args.mode != "paper";
  if (!google::protobuf::TextFormat::ParseFromString(args.exploration, &options.exploration)) {
    return ReportError(context,
                       absl::InvalidArgumentError(
                           "--exploration is not ExplorationConfig in protobuf text format "
                           "(e.g. 'travel_cost: 0.2 grid_resolution: 0.05'): '" +
                           args.exploration + "'"),
                       "sim explore");
  }
  options.duration_s = args.duration_s;
  options.seed = args.seed;
  options.half_degree = args.half_degree;
  options.odometry_error = args.odometry_error;
  options.record_dir = args.record;
  // Per scan: the server's processing and planning, bounded like any request (--timeout).
  options.answer_timeout =
      context.globals.timeout_s > 0 ? absl::Seconds(context.globals.timeout_s) : absl::Hours(24);
  if (args.robots > 1 || !args.map.empty()) {
    return RunTeamExplore(context, args, *std::move(world), std::move(options));
  }
  const fs::path out_dir =
      args.out_dir.empty()
          ? fs::path("out") / fmt::format("sim-{}-{}-s{}", world->name, args.mode, args.seed)
          : fs::path(args.out_dir);

  ProgressBar progress(context.err, static_cast<int>(std::ceil(args.duration_s)), "s simulated",
                       context.err_is_tty);
  auto result = RunExploration(*context.ConnectSlam(), *world, options, [&](const ScanRecord& r) {
    progress.Update(static_cast<int>(r.time));
  });
  progress.Finish();
  if (!result.ok()) return ReportError(context, result.status(), "sim explore " + world->name);

  nlohmann::json summary = ExploreSummary(*result);
  summary["out_dir"] = out_dir.string();
  if (absl::Status s = WriteExploreFiles(out_dir, *result, *world, summary); !s.ok()) {
    return ReportError(context, s, out_dir.string());
  }
  if (context.globals.json) {
    PrintJson(context.out, summary);
  } else {
    PrintSummary(context.out, summary);
  }
  return kExitOk;
}

// Several robots: every robot's true path in a colour of its own (its estimate wide and light
// underneath) over the true walls, with the union of their mapped segments.
MapScene TeamScene(const TeamExploreResult& result, const adapters::World& world) {
  MapScene scene;
  scene.title = fmt::format("{} ({}, {} robots, seed {}): {:.0f} s, completeness {:.0f}%",
                            result.world, result.mode, result.robots.size(), result.seed,
                            result.sim_time_s, 100 * result.completeness);
  for (const adapters::Wall& wall : world.walls) {
    ScenePolyline line;
    line.points = {{wall.x1, wall.y1}, {wall.x2, wall.y2}};
    line.color = {200, 200, 200};
    line.width_px = 5;
    line.label = scene.references.empty() ? "true walls" : "";
    scene.references.push_back(std::move(line));
  }
  scene.segments = result.union_map_world;
  const Rgb colours[] = {{200, 30, 30}, {20, 90, 200}, {20, 150, 60}, {200, 120, 0},
                         {140, 40, 170}, {0, 150, 160}};
  for (size_t k = 0; k < result.robots.size(); ++k) {
    const Rgb c = colours[k % std::size(colours)];
    const ExploreResult& run = result.robots[k].run;
    ScenePolyline estimate = Path(run, &ScanRecord::estimate_world,
                                  {static_cast<uint8_t>((c.r + 2 * 255) / 3),
                                   static_cast<uint8_t>((c.g + 2 * 255) / 3),
                                   static_cast<uint8_t>((c.b + 2 * 255) / 3)},
                                  fmt::format("robot {} estimate", k + 1));
    estimate.width_px = 3;
    scene.polylines.push_back(std::move(estimate));
    scene.polylines.push_back(
        Path(run, &ScanRecord::true_pose, c, fmt::format("robot {} true path", k + 1)));
  }
  return scene;
}

void PrintTeamSummary(std::ostream& out, const nlohmann::json& s) {
  Table table({{"robot"},
               {"done at (s)", true},
               {"completeness", true},
               {"loc. error mean (m)", true},
               {"distance (m)", true},
               {"scans", true},
               {"state"},
               {"rooms entered"}});
  auto time = [](double t) { return t < 0 ? std::string("-") : FormatNumber(t, 0); };
  for (const nlohmann::json& r : s["per_robot"]) {
    table.AddRow({std::to_string(r["robot"].get<int>()), time(r["done_time_s"].get<double>()),
                  FormatPercent(r["completeness"].get<double>()),
                  FormatNumber(r["loc_error_mean_m"].get<double>(), 3),
                  FormatNumber(r["distance_m"].get<double>(), 1),
                  std::to_string(r["scans"].get<int>()), r["final_state"].get<std::string>(),
                  std::to_string(r["rooms_entered"].size())});
  }
  table.AddRow({"all", time(s["done_time_s"].get<double>()),
                FormatPercent(s["completeness"].get<double>()),
                FormatNumber(s["loc_error_mean_m"].get<double>(), 3),
                FormatNumber(s["distance_m"].get<double>(), 1), "", "",
                fmt::format("{} of {}, {} by several", s["rooms_entered"].get<int>(),
                            s["rooms"].get<int>(), s["rooms_explored_twice"].get<int>())});
  table.Print(out);
  out << "wrote " << s["out_dir"].get<std::string>()
      << "/map.svg, map.png, summary.json and robot<k>/ (each robot's files)\n";
}

int RunTeamExplore(CommandContext& context, const ExploreArgs& args, adapters::World world,
                   ExploreOptions options) {
  TeamExploreOptions team;
  team.run = std::move(options);
  team.robots = args.robots;
  team.map = args.map;
  team.known_starts = args.known_starts;
  const fs::path out_dir =
      args.out_dir.empty()
          ? fs::path("out") / fmt::format("sim-{}-{}-{}robots-s{}", world.name, args.mode,
                                          args.robots, args.seed)
          : fs::path(args.out_dir);
  ProgressBar progress(context.err, static_cast<int>(std::ceil(args.duration_s)), "s simulated",
                       context.err_is_tty);
  auto result = RunTeamExploration(*context.ConnectSlam(), world, team, [&](double t) {
    progress.Update(static_cast<int>(t));
  });
  progress.Finish();
  if (!result.ok()) return ReportError(context, result.status(), "sim explore " + world.name);
  nlohmann::json summary = TeamExploreSummary(*result);
  summary["out_dir"] = out_dir.string();
  for (size_t k = 0; k < result->robots.size(); ++k) {
    const fs::path dir = out_dir / fmt::format("robot{}", k + 1);
    nlohmann::json robot = summary["per_robot"][k];
    robot["out_dir"] = dir.string();
    if (absl::Status s = WriteExploreFiles(dir, result->robots[k].run, world, robot); !s.ok()) {
      return ReportError(context, s, dir.string());
    }
  }
  if (absl::Status s = WriteMapPictures(TeamScene(*result, world), out_dir / "map.svg",
                                        out_dir / "map.png");
      !s.ok()) {
    return ReportError(context, s, out_dir.string());
  }
  std::ofstream file(out_dir / "summary.json");
  file << summary.dump(2) << "\n";
  file.close();
  if (!file) {
    return ReportError(context, absl::PermissionDeniedError("cannot write summary.json"),
                       out_dir.string());
  }
  if (context.globals.json) {
    PrintJson(context.out, summary);
  } else {
    PrintTeamSummary(context.out, summary);
  }
  return kExitOk;
}

int RunWorlds(CommandContext& context) {
  nlohmann::json list = nlohmann::json::array();
  Table table({{"world"}, {"walls", true}, {"wall length (m)", true}, {"visible (m)", true}});
  for (const std::string& name : adapters::BuiltinWorldNames()) {
    auto world = adapters::LoadWorld(name);
    if (!world.ok()) return ReportError(context, world.status(), name);
    // What the laser can see from where the robot fits: what completeness can reach at most.
    const double visible = adapters::SampleLength(adapters::VisibleWalls(*world));
    list.push_back({{"name", name},
                    {"walls", world->walls.size()},
                    {"wall_length_m", world->WallLength()},
                    {"visible_wall_m", visible}});
    table.AddRow({name, std::to_string(world->walls.size()), FormatNumber(world->WallLength(), 1),
                  FormatNumber(visible, 1)});
  }
  if (context.globals.json) {
    PrintJson(context.out, {{"worlds", list}});
  } else {
    table.Print(context.out);
  }
  return kExitOk;
}

}  // namespace

void AddSimCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* sim = app.add_subcommand("sim", "Simulated Pioneer 3-DX + SICK LMS200 robot");
  sim->require_subcommand(1);

  auto args = std::make_shared<ExploreArgs>();
  CLI::App* explore = sim->add_subcommand(
      "explore",
      "Closed loop: the server steers a simulated robot until it says DONE (or STUCK) or the "
      "simulated time is up; write true, estimated and odometry trajectories, map and timeline "
      "pictures, timeline.csv and summary.json");
  explore->add_option("--world", args->world, "Built-in world name (see `sim worlds`) or a file")
      ->required();
  explore->add_option("--mode", args->mode,
                      "active: the goal layer over the paper's planner; paper: the paper's "
                      "one-step planner alone; wander: the paper's baseline; frontier: nearest "
                      "frontier (the usual frontier explorer)")
      ->check(CLI::IsMember({"active", "paper", "wander", "frontier"}))
      ->capture_default_str();
  explore->add_option("--duration", args->duration_s,
                      "Simulated seconds at most (active and frontier runs stop at DONE)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  explore->add_option("--seed", args->seed, "Simulator seed")->capture_default_str();
  explore->add_flag("--half-degree", args->half_degree,
                    "LMS200 0.5-degree mode (361 beams) instead of 1 degree (181)");
  explore->add_option("--odometry-error", args->odometry_error,
                      "Scale of the simulated odometry error (0 = perfect, 1 = default: 1 % "
                      "distance and 0.5 % turn scale error, 0.005 rad/m drift, 2 % random)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  explore->add_option("--exploration", args->exploration,
                      "Exploration parameters to override, ExplorationConfig fields in protobuf "
                      "text format (e.g. 'travel_cost: 0.2 revisit_variance: 1'; see "
                      "docs/exploration.md). max_linear and max_angular are the simulated "
                      "base's limits too (default the paper's 0.15 m/s, 0.17 rad/s)");
  explore->add_option("--robots", args->robots,
                      "Robots exploring together, each its own session in the map --map "
                      "(docs/exploration.md, \"Several robots\")")
      ->check(CLI::Range(1, 6))
      ->capture_default_str();
  explore->add_option("--map", args->map,
                      "Shared map the robots' sessions join (created when missing; it must hold "
                      "no trajectory yet); needed with --robots above 1");
  explore->add_option("--known-starts", args->known_starts,
                      "Several robots: the robots after the first are tied into the map at their "
                      "true starts (initial_map_pose); false: the server's search ties them in")
      ->capture_default_str();
  explore->add_option("--out", args->out_dir,
                      "Output folder (default ./out/sim-<world>-<mode>-s<seed>)");
  explore->add_option("--record", args->record,
                      "Also write each robot's odometry and scans as sent, as CARMEN logs "
                      "DIR/robot<k>.clf: the same robot data replayed later with `waymark slam "
                      "replay` (e.g. into a map with other server settings)");
  registry.Add(explore, [args](CommandContext& context) { return RunExplore(context, *args); });

  CLI::App* worlds = sim->add_subcommand("worlds", "List the built-in worlds");
  registry.Add(worlds, [](CommandContext& context) { return RunWorlds(context); });
}

}  // namespace waymark::cli
