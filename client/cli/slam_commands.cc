// `waymark slam ...`: laser SLAM sessions. replay and odometry live in slam_replay.cc; the small
// session commands (list, map, import-map, trajectory, close, delete) here.
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/cli/command.h"
#include "client/cli/localize_flags.h"
#include "client/cli/map_frame.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"
#include "client/common/stop_signals.h"
#include "client/datasets/ros_map.h"
#include "client/datasets/tum_trajectory.h"
#include "client/render/slam_output.h"
#include "client/sessions/session_grid.h"
#include "client/sessions/slam_replay.h"

namespace waymark::cli {
namespace {

std::string StateName(v1::Session::State state) {
  switch (state) {
    case v1::Session::OPEN: return "open";
    case v1::Session::CLOSED: return "closed";
    default: return "unspecified";
  }
}

// A grid's size and place, without its cells.
nlohmann::json GridJson(const v1::OccupancyGrid& grid) {
  return {{"width", grid.width()},
          {"height", grid.height()},
          {"resolution", grid.resolution()},
          {"origin", {grid.origin().x(), grid.origin().y()}}};
}

// "412 x 380 cells at 0.05 m, origin (-10.2, -3.5)"
std::string DescribeGrid(const v1::OccupancyGrid& grid) {
  return fmt::format("{} x {} cells at {:g} m, origin ({:g}, {:g})", grid.width(), grid.height(),
                     grid.resolution(), grid.origin().x(), grid.origin().y());
}

// slam list's "map check" column: a closed session's final map as its self-check judged it.
std::string MapCheckCell(const v1::Session& session) {
  if (!session.has_self_check()) return "-";  // open, no scans kept, or closed by an older server
  const v1::MapSelfCheck& check = session.self_check();
  if (check.consistent()) {
    return fmt::format("consistent ({:.1f}%)", 100.0 * check.contradicted_fraction());
  }
  return fmt::format("CONTRADICTS: {} areas, {:.1f}%", check.areas_contradicting(),
                     100.0 * check.contradicted_fraction());
}

int RunList(CommandContext& context, const std::string& robot) {
  auto sessions = context.ConnectSlam()->ListSessions(robot);
  if (!sessions.ok()) return ReportError(context, sessions.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*sessions));
    return kExitOk;
  }
  // A fleet on PostgreSQL: which server serves each session (a column only then).
  const bool fleet = std::any_of(sessions->sessions().begin(), sessions->sessions().end(),
                                 [](const v1::Session& s) { return !s.served_by().empty(); });
  // Sessions in shared maps (`waymark map`): which map (a column only then).
  const bool in_maps = std::any_of(sessions->sessions().begin(), sessions->sessions().end(),
                                   [](const v1::Session& s) { return !s.map().empty(); });
  std::vector<Table::Column> columns = {{"session"}, {"robot"}, {"state"}, {"scans", true},
                                        {"segments", true}, {"rejected", true}, {"map check"},
                                        {"resident"}, {"name"}};
  if (fleet) columns.insert(columns.end() - 1, {"served by"});
  if (in_maps) columns.insert(columns.end() - 1, {"in map"});
  Table table(columns);
  for (const v1::Session& s : sessions->sessions()) {
    std::vector<std::string> row = {s.session_id(), s.robot_id(), StateName(s.state()),
                                    std::to_string(s.scans_processed()),
                                    std::to_string(s.segments()),
                                    std::to_string(s.messages_rejected()), MapCheckCell(s),
                                    s.resident() ? "yes" : "no", s.name()};
    if (fleet) row.insert(row.end() - 1, s.served_by().empty() ? "-" : s.served_by());
    if (in_maps) row.insert(row.end() - 1, s.map().empty() ? "-" : s.map());
    table.AddRow(row);
  }
  if (table.empty()) {
    context.out << "no sessions\n";
  } else {
    table.Print(context.out);
  }
  return kExitOk;
}

struct MapArgs {
  std::string session_id;
  std::string out;
  std::optional<double> resolution;  // of the occupancy grid; unset = the server's default
};

int RunMap(CommandContext& context, const MapArgs& args) {
  auto client = context.ConnectSlam();
  auto map = client->GetMap(args.session_id);
  if (!map.ok()) return ReportError(context, map.status());
  auto trajectory = client->GetTrajectory(args.session_id);
  if (!trajectory.ok()) return ReportError(context, trajectory.status());
  const SlamOutTarget target =
      SlamOutTargetOf(args.out.empty() ? std::filesystem::path("out") / args.session_id
                                       : std::filesystem::path(args.out));
  // A folder also gets the occupancy grid; a session without one still gets its segment map.
  SessionGrid grid;
  if (target.is_folder()) {
    auto fetched = FetchSessionGrid(*client, args.session_id, args.resolution);
    if (!fetched.ok()) return ReportError(context, fetched.status(), "GetOccupancyGrid");
    grid = *std::move(fetched);
  }
  auto written = WriteSlamOutputs(
      target, *map, *trajectory,
      fmt::format("session {}: {} segments", args.session_id, map->segments_size()));
  if (!written.ok()) return ReportError(context, written.status(), target.path.string());
  if (grid.grid) {
    auto grid_files = WriteGridFiles(target.path, *grid.grid, *trajectory,
                                     map->has_self_check() ? &map->self_check() : nullptr);
    if (!grid_files.ok()) return ReportError(context, grid_files.status(), target.path.string());
    written->insert(written->end(), grid_files->begin(), grid_files->end());
  }
  if (context.globals.json) {
    nlohmann::json files = nlohmann::json::array();
    for (const auto& file : *written) files.push_back(file.string());
    nlohmann::json json = {{"session_id", args.session_id},
                           {"segments", map->segments_size()},
                           {"map_revision", map->map_revision()},
                           {"trajectory_poses", trajectory->poses_size()},
                           {target.is_folder() ? "out_dir" : "out", target.path.string()},
                           {"files", files},
                           {"grid", grid.grid ? GridJson(*grid.grid) : nlohmann::json(nullptr)}};
    if (!grid.missing.empty()) json["grid_note"] = grid.missing;
    if (map->has_self_check()) {
      json["self_check"] = {{"consistent", map->self_check().consistent()},
                            {"verdict", map->self_check().verdict()},
                            {"areas_contradicting", map->self_check().areas_contradicting()},
                            {"contradicted_fraction", map->self_check().contradicted_fraction()}};
    }
    PrintJson(context.out, json);
  } else {
    const std::string grid_text =
        grid.grid ? fmt::format(", occupancy grid {}", DescribeGrid(*grid.grid)) : "";
    context.out << fmt::format("{} segments (revision {}), {} poses{}: wrote {}\n",
                               map->segments_size(), map->map_revision(), trajectory->poses_size(),
                               grid_text, DescribeWritten(*written));
    if (!grid.missing.empty()) context.out << grid.missing << "\n";
    if (map->has_self_check()) {
      context.out << "map self-check: " << map->self_check().verdict() << "\n";
    }
  }
  return kExitOk;
}

struct ImportMapArgs {
  std::string yaml;
  std::string name;
  std::string robot_id = "maps";
};

int RunImportMap(CommandContext& context, const ImportMapArgs& args) {
  auto grid = ReadRosMap(args.yaml);
  if (!grid.ok()) return ReportError(context, grid.status());
  const std::string name = args.name.empty() ? "import of " + args.yaml : args.name;
  auto session = context.ConnectSlam()->ImportMap(args.robot_id, name, *grid);
  if (absl::IsUnimplemented(session.status())) {
    return ReportError(
        context,
        absl::UnimplementedError("the server does not import maps: it is older than this client"),
        "ImportMap");
  }
  if (!session.ok()) return ReportError(context, session.status(), "ImportMap");
  if (context.globals.json) {
    nlohmann::json json = ProtoToJson(*session);
    json["grid"] = GridJson(*grid);
    PrintJson(context.out, json);
  } else {
    context.out << fmt::format("imported {} ({}) as session {}\n", args.yaml, DescribeGrid(*grid),
                               session->session_id());
    context.out << fmt::format(
        "localize on it: waymark slam replay LOG --localize-on {0}, or waymark robot ... "
        "--localize-on {0}\n",
        session->session_id());
  }
  return kExitOk;
}

absl::StatusOr<v1::Session> FindSession(client::SlamClient& client, const std::string& session_id);

// The session's poses moved into its shared map's frame (`--frame map`): origin (+) pose, with
// the origin its trajectory was tied in at, or, when the server followed it after its tie, its
// origin at each pose's stamp. FAILED_PRECONDITION when the session is in no map or
// not yet tied into it.
absl::Status ToMapFrame(client::SlamClient& client, const std::string& session_id,
                        v1::Trajectory* trajectory) {
  absl::StatusOr<v1::Session> session = FindSession(client, session_id);
  if (!session.ok()) return session.status();
  if (session->map().empty()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "session ", session_id, " is in no shared map: it has only its own frame (leave out "
        "--frame map)"));
  }
  absl::StatusOr<v1::Map> map = client.GetMapInfo(session->map(), /*node_origins=*/true);
  if (!map.ok()) return map.status();
  for (const v1::MapTrajectory& t : map->trajectories()) {
    if (t.session_id() != session_id) continue;
    if (!t.tied_in()) {
      return absl::FailedPreconditionError(absl::StrCat(
          "session ", session_id, " is not yet in map \"", session->map(),
          "\": the server has not found where its robot is in it (`waymark map show ",
          session->map(), "`)"));
    }
    MoveToMapFrame(t, trajectory);
    return absl::OkStatus();
  }
  return absl::NotFoundError(
      absl::StrCat("map \"", session->map(), "\" does not list session ", session_id));
}

int RunTrajectory(CommandContext& context, const std::string& session_id,
                  const std::string& out, const std::string& frame) {
  auto client = context.ConnectSlam();
  auto trajectory = client->GetTrajectory(session_id);
  if (!trajectory.ok()) return ReportError(context, trajectory.status());
  if (frame == "map") {
    if (absl::Status s = ToMapFrame(*client, session_id, &*trajectory); !s.ok()) {
      return ReportError(context, s);
    }
  }
  if (!out.empty()) {
    if (absl::Status s = WriteTumFile(out, PosesOf(*trajectory)); !s.ok()) {
      return ReportError(context, s);
    }
    context.err << "wrote " << trajectory->poses_size() << " poses to " << out << "\n";
    return kExitOk;
  }
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*trajectory));
  } else {
    WriteTum(context.out, PosesOf(*trajectory));
  }
  return kExitOk;
}

// The session as ListSessions describes it; NOT_FOUND when the list does not hold it.
absl::StatusOr<v1::Session> FindSession(client::SlamClient& client, const std::string& session_id) {
  auto sessions = client.ListSessions();
  if (!sessions.ok()) return sessions.status();
  for (const v1::Session& session : sessions->sessions()) {
    if (session.session_id() == session_id) return session;
  }
  return absl::NotFoundError("session " + session_id + " is not listed");
}

int RunClose(CommandContext& context, const std::string& session_id) {
  auto client = context.ConnectSlam();
  auto session = client->CloseSession(session_id);
  bool already_closed = false;
  if (absl::IsFailedPrecondition(session.status())) {
    // The server refuses to close a closed session (e.g. right after `slam replay`, which closes
    // its own): that is what the user asked for, so say so and succeed. Any other refusal (a
    // robot still streaming) stays an error.
    auto listed = FindSession(*client, session_id);
    if (listed.ok() && listed->state() == v1::Session::CLOSED) {
      session = *std::move(listed);
      already_closed = true;
    }
  }
  if (!session.ok()) return ReportError(context, session.status());
  if (context.globals.json) {
    nlohmann::json json = ProtoToJson(*session);
    json["already_closed"] = already_closed;
    PrintJson(context.out, json);
  } else {
    const std::string what = already_closed ? "session " + session_id + " is already closed"
                                            : "closed session " + session_id;
    context.out << fmt::format("{}: {} scans, {} segments\n", what, session->scans_processed(),
                               session->segments());
  }
  return kExitOk;
}

int RunDelete(CommandContext& context, const std::string& session_id, bool force) {
  auto deleted = context.ConnectSlam()->DeleteSession(session_id, force);
  if (absl::IsFailedPrecondition(deleted.status()) && !force) {
    return ReportError(context,
                       absl::FailedPreconditionError(absl::StrCat(
                           deleted.status().message(),
                           "; to close and delete it at once: waymark slam delete ", session_id,
                           " --force")));
  }
  if (!deleted.ok()) return ReportError(context, deleted.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*deleted));
  } else {
    const v1::Session& session = deleted->session();
    context.out << fmt::format(
        "deleted session {} (robot {}{}{}): {} scans, {} segments, {} trajectory poses{}\n",
        session_id, session.robot_id(), session.name().empty() ? "" : ", ", session.name(),
        session.scans_processed(), session.segments(), deleted->trajectory_poses(),
        deleted->closed_first() ? "; it was open and was closed first" : "");
  }
  return kExitOk;
}

// --name VALUE into an optional<double>.
void AddOptionalNumber(CLI::App* command, const std::string& name,
                       std::optional<double>* target, const std::string& help) {
  command
      ->add_option_function<double>(
          name, [target](const double& value) { *target = value; }, help)
      ->check(CLI::NonNegativeNumber);
}

// --resolution M of the occupancy grid, within the range GetOccupancyGrid accepts.
void AddGridResolutionOption(CLI::App* command, std::optional<double>* target) {
  command
      ->add_option_function<double>(
          "--resolution", [target](const double& value) { *target = value; },
          "Occupancy grid cell size in metres, 0.01 to 1 (default: the server's, 0.05)")
      ->check(CLI::Range(0.01, 1.0));
}

// --restamp and --rate HZ (which needs --restamp).
void AddRestampFlags(CLI::App* command, bool* restamp, double* rate_hz) {
  CLI::Option* flag = command->add_flag(
      "--restamp", *restamp,
      "Ignore the log's stamps: stamp the laser lines from their order in the file at --rate "
      "(for logs whose stamps repeat or are all 0); the summary says the stamps were synthesized");
  command
      ->add_option("--rate", *rate_hz,
                   fmt::format("Laser rate in Hz for --restamp (default {:g}, the raw CARMEN logs' "
                               "rate; corrected logs keep about one scan in 1-5 s)",
                               adapters::kDefaultRestampRateHz))
      ->check(CLI::PositiveNumber)
      ->needs(flag);
}

// --scan-topic and --odom-topic: which topics of a bag a replay reads.
void AddBagTopicFlags(CLI::App* command, std::string* scan_topic, std::string* odom_topic) {
  command->add_option("--scan-topic", *scan_topic,
                      "Bags: the sensor_msgs/LaserScan topic (default: the bag's only one)");
  command->add_option(
      "--odom-topic", *odom_topic,
      "Bags: the nav_msgs/Odometry topic (default: the bag's only one, else the odom -> base "
      "chain of /tf); 'tf' forces TF, 'none' replays with no odometry (the robot at the origin)");
}

}  // namespace

void AddSlamCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* slam = app.add_subcommand("slam", "Laser SLAM sessions");
  slam->require_subcommand(1);

  auto replay_args = std::make_shared<ReplayArgs>();
  CLI::App* replay = slam->add_subcommand(
      "replay",
      "Stream a CARMEN log (FLASER / ROBOTLASER1 lines; plain, .gz or .bz2) or a ROS bag (ROS 1 "
      ".bag, rosbag2 folder or .db3, MCAP: a LaserScan topic with odometry from an Odometry topic "
      "or TF, the laser's mounting from TF) into a new session, "
      "close it, and write trajectory.txt (TUM), map.svg, map.png, summary.json and, when the "
      "session has an occupancy grid, map.pgm + map.yaml (ROS map_server) and occupancy.png. A log "
      "whose stamps are broken (most lines skipped) is reported and exits 1: use --restamp. A "
      "final map that contradicts itself (its self-check: a fold, a doubled corridor) is warned "
      "about and exits 3. Ctrl-C stops early: the session is closed and the outputs written, "
      "marked partial (exit 130)");
  replay->add_option("LOG", replay_args->log, "CARMEN log file, or a ROS bag (see --scan-topic)")
      ->required();
  AddBagTopicFlags(replay, &replay_args->scan_topic, &replay_args->odom_topic);
  replay->add_flag("--realtime", replay_args->realtime, "Send at the log's pace, not full speed");
  replay->add_option("--speed", replay_args->speed,
                     "Send at the log's pace times this (e.g. 20: 20 s of the log a second), not "
                     "full speed")
      ->check(CLI::PositiveNumber);
  AddRestampFlags(replay, &replay_args->restamp, &replay_args->rate_hz);
  replay
      ->add_option_function<std::string>(
          "--odometry-lag",
          [replay_args](const std::string& value) {
            if (value == "auto") {
              replay_args->odometry_lag.reset();
              return;
            }
            int lag = 0;
            const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), lag);
            if (error != std::errc() || end != value.data() + value.size() || lag < -100 ||
                lag > 100) {
              throw CLI::ValidationError("--odometry-lag", "'auto' or a whole number of scans");
            }
            replay_args->odometry_lag = lag;
          },
          "CARMEN logs: each scan takes the odometry the log gives the scan N lines later; 'auto' "
          "(the default) finds N from the log itself (a log that pairs its scans with the "
          "odometry of other scans is put right and told), 0 keeps the log's pairing")
      ->type_name("auto|N");
  replay->add_option("--out", replay_args->out_dir,
                     "Output folder (default ./out/<log name>); a path ending in .svg or .png "
                     "writes only that map picture");
  replay->add_option("--robot", replay_args->robot_id, "Robot id of the session")
      ->capture_default_str();
  replay->add_option("--name", replay_args->name, "Session name (default 'replay of <log>')");
  replay->add_option("--max-scans", replay_args->max_scans, "Stop after N scans (0 = all)")
      ->check(CLI::NonNegativeNumber);
  replay
      ->add_option("--window", replay_args->window,
                   "Scans in flight at most (the server's session queue holds 64 messages)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  replay->add_flag("--show-odometry", replay_args->show_odometry,
                   "Draw the raw odometry path in the map pictures");
  AddOptionalNumber(replay, "--max-range", &replay_args->max_range,
                    "Readings beyond M metres are dropped (server default 6)");
  AddOptionalNumber(replay, "--odom-xy-per-m", &replay_args->odom_xy_per_m,
                    "Odometry noise: metres per metre travelled");
  AddOptionalNumber(replay, "--odom-theta-per-rad", &replay_args->odom_theta_per_rad,
                    "Odometry noise: radians per radian turned");
  AddOptionalNumber(replay, "--odom-theta-per-m", &replay_args->odom_theta_per_m,
                    "Odometry noise: radians per metre travelled");
  AddOptionalNumber(replay, "--match-chi2", &replay_args->match_chi2,
                    "Association gate (chi-square, 2 dof)");
  AddGridResolutionOption(replay, &replay_args->grid_resolution);
  replay->add_flag("--allow-inconsistent-map", replay_args->allow_inconsistent_map,
                   "Exit 0 even when the final map contradicts itself (still warned about)");
  CLI::Option* localize_on = AddLocalizeFlags(replay, &replay_args->localize);
  replay->add_option("--map", replay_args->map,
                     "Join this shared map (`waymark map create NAME`) as one robot's trajectory");
  // --initial-pose is the start in the map either way: the one localized on (--localize-on) or
  // the shared one joined (--map; without it the server finds the robot from its scans). Its
  // parser (localize_flags.h) puts it in the localization config; RunReplay moves it for --map.
  if (CLI::Option* initial = replay->get_option_no_throw("--initial-pose")) {
    initial->remove_needs(localize_on);
    initial->description(
        "Where the robot starts: X,Y,THETA (m, m, rad) in the --localize-on map (else the "
        "whole map is searched for the first fix) or in the --map's frame (else the server finds "
        "it from the scans)");
  }
  replay->add_option_function<std::string>(
      "--scans",
      [replay_args](const std::string& value) {
        absl::StatusOr<ScanSlice> slice = ParseScanSlice(value);
        if (!slice.ok()) throw CLI::ValidationError("--scans", std::string(slice.status().message()));
        replay_args->scans = *slice;
      },
      "Only scans FIRST to LAST-1 of the recording (0-based; FIRST: to the end), as one robot "
      "driving that stretch");
  registry.Add(replay, [replay_args](CommandContext& c) {
    if (replay_args->localize && replay_args->localize->map_session_id().empty()) {
      // Only --initial-pose: a start in the shared map, not a localization.
      if (replay_args->map.empty()) {
        return ReportError(c, absl::InvalidArgumentError(
                                  "--initial-pose needs --localize-on (a map to localize on) or "
                                  "--map (a shared map to join)"));
      }
      replay_args->initial_map_pose = replay_args->localize->initial_pose();
      replay_args->localize.reset();
    }
    StopSignals signals;  // Ctrl-C: stop sending, close the session, write partial outputs
    return RunSlamReplay(c, *replay_args, [&signals] { return signals.stop_requested().load(); });
  });

  auto odometry_args = std::make_shared<OdometryArgs>();
  CLI::App* odometry = slam->add_subcommand(
      "odometry",
      "Write the raw odometry of a CARMEN log's laser lines as a TUM trajectory (no server; the "
      "baseline for `eval relations`); broken stamps are reported and exit 1, as in replay");
  odometry->add_option("LOG", odometry_args->log, "CARMEN log file, or a ROS bag")->required();
  AddBagTopicFlags(odometry, &odometry_args->scan_topic, &odometry_args->odom_topic);
  odometry->add_option("--out", odometry_args->out, "TUM file to write")->required();
  odometry->add_option("--max-scans", odometry_args->max_scans, "Stop after N scans (0 = all)")
      ->check(CLI::NonNegativeNumber);
  AddRestampFlags(odometry, &odometry_args->restamp, &odometry_args->rate_hz);
  registry.Add(odometry,
               [odometry_args](CommandContext& c) { return RunSlamOdometry(c, *odometry_args); });

  auto robot = std::make_shared<std::string>();
  CLI::App* list = slam->add_subcommand("list", "List sessions");
  list->add_option("--robot", *robot, "Only this robot's sessions");
  registry.Add(list, [robot](CommandContext& c) { return RunList(c, *robot); });

  auto map_args = std::make_shared<MapArgs>();
  CLI::App* map = slam->add_subcommand(
      "map",
      "Write a session's map.svg, map.png, trajectory.txt and, when it has an occupancy grid, "
      "map.pgm + map.yaml (ROS map_server) and occupancy.png");
  map->add_option("SESSION", map_args->session_id, "Session id")->required();
  map->add_option("--out", map_args->out,
                  "Output folder (default ./out/<session>); a path ending in .svg or .png writes "
                  "only that picture");
  AddGridResolutionOption(map, &map_args->resolution);
  registry.Add(map, [map_args](CommandContext& c) { return RunMap(c, *map_args); });

  auto import_args = std::make_shared<ImportMapArgs>();
  CLI::App* import = slam->add_subcommand(
      "import-map",
      "Store a ROS map_server map (map.yaml and the PGM it names, e.g. from `slam map`) as a new "
      "closed session to localize on (--localize-on); prints its id");
  import->add_option("MAP_YAML", import_args->yaml, "The map's YAML file")->required();
  import->add_option("--name", import_args->name, "Session name (default 'import of <file>')");
  import->add_option("--robot", import_args->robot_id, "Robot id of the session")
      ->capture_default_str();
  registry.Add(import, [import_args](CommandContext& c) { return RunImportMap(c, *import_args); });

  struct SessionArgs {
    std::string session_id;
    std::string out;
    std::string frame = "session";
  };

  auto trajectory_args = std::make_shared<SessionArgs>();
  CLI::App* trajectory =
      slam->add_subcommand("trajectory", "Print a session's trajectory (TUM format)");
  trajectory->add_option("SESSION", trajectory_args->session_id, "Session id")->required();
  trajectory->add_option("--out", trajectory_args->out, "Write to FILE instead of stdout");
  trajectory
      ->add_option("--frame", trajectory_args->frame,
                   "session (its own frame) or map (its shared map's frame, once tied in)")
      ->check(CLI::IsMember({"session", "map"}));
  registry.Add(trajectory, [trajectory_args](CommandContext& c) {
    return RunTrajectory(c, trajectory_args->session_id, trajectory_args->out,
                         trajectory_args->frame);
  });

  auto close_id = std::make_shared<std::string>();
  CLI::App* close = slam->add_subcommand(
      "close", "Close a session (it stays readable); a session already closed is left as it is");
  close->add_option("SESSION", *close_id, "Session id")->required();
  registry.Add(close, [close_id](CommandContext& c) { return RunClose(c, *close_id); });

  struct DeleteArgs {
    std::string session_id;
    bool force = false;
  };
  auto delete_args = std::make_shared<DeleteArgs>();
  CLI::App* remove = slam->add_subcommand(
      "delete",
      "Delete a session with its map, trajectory and checkpoint from the server (for good); an "
      "open session needs --force");
  remove->add_option("SESSION", delete_args->session_id, "Session id")->required();
  remove->add_flag("--force", delete_args->force,
                   "Close the session first if it is open (a session a robot is streaming to is "
                   "still refused)");
  registry.Add(remove, [delete_args](CommandContext& c) {
    return RunDelete(c, delete_args->session_id, delete_args->force);
  });
}

}  // namespace waymark::cli
