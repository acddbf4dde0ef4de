// `waymark slam ...`: laser SLAM sessions. replay and odometry live in slam_replay.cc; the small
// session commands (list, map, trajectory, close) here.
#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <string>

#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"
#include "client/render/slam_output.h"
#include "client/sessions/slam_replay.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {
namespace {

std::string StateName(v1::Session::State state) {
  switch (state) {
    case v1::Session::OPEN: return "open";
    case v1::Session::CLOSED: return "closed";
    default: return "unspecified";
  }
}

int RunList(CommandContext& context, const std::string& robot) {
  auto sessions = context.ConnectSlam()->ListSessions(robot);
  if (!sessions.ok()) return ReportError(context, sessions.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*sessions));
    return kExitOk;
  }
  Table table({{"session"}, {"robot"}, {"state"}, {"scans", true}, {"segments", true},
               {"rejected", true}, {"resident"}, {"name"}});
  for (const v1::Session& s : sessions->sessions()) {
    table.AddRow({s.session_id(), s.robot_id(), StateName(s.state()),
                  std::to_string(s.scans_processed()), std::to_string(s.segments()),
                  std::to_string(s.messages_rejected()), s.resident() ? "yes" : "no", s.name()});
  }
  if (table.empty()) {
    context.out << "no sessions\n";
  } else {
    table.Print(context.out);
  }
  return kExitOk;
}

int RunMap(CommandContext& context, const std::string& session_id, const std::string& out) {
  auto client = context.ConnectSlam();
  auto map = client->GetMap(session_id);
  if (!map.ok()) return ReportError(context, map.status());
  auto trajectory = client->GetTrajectory(session_id);
  if (!trajectory.ok()) return ReportError(context, trajectory.status());
  const std::filesystem::path dir =
      out.empty() ? std::filesystem::path("out") / session_id : std::filesystem::path(out);
  if (absl::Status s = WriteSlamFiles(dir, *map, *trajectory,
                                      fmt::format("session {}: {} segments", session_id,
                                                  map->segments_size()));
      !s.ok()) {
    return ReportError(context, s, dir.string());
  }
  if (context.globals.json) {
    PrintJson(context.out, {{"session_id", session_id},
                            {"segments", map->segments_size()},
                            {"map_revision", map->map_revision()},
                            {"trajectory_poses", trajectory->poses_size()},
                            {"out_dir", dir.string()}});
  } else {
    context.out << fmt::format("{} segments (revision {}), {} poses: wrote {}/map.svg, map.png, "
                               "trajectory.txt\n",
                               map->segments_size(), map->map_revision(),
                               trajectory->poses_size(), dir.string());
  }
  return kExitOk;
}

int RunTrajectory(CommandContext& context, const std::string& session_id,
                  const std::string& out) {
  auto trajectory = context.ConnectSlam()->GetTrajectory(session_id);
  if (!trajectory.ok()) return ReportError(context, trajectory.status());
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

int RunClose(CommandContext& context, const std::string& session_id) {
  auto session = context.ConnectSlam()->CloseSession(session_id);
  if (!session.ok()) return ReportError(context, session.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*session));
  } else {
    context.out << fmt::format("closed session {}: {} scans, {} segments\n", session_id,
                               session->scans_processed(), session->segments());
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

}  // namespace

void AddSlamCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* slam = app.add_subcommand("slam", "Laser SLAM sessions");
  slam->require_subcommand(1);

  auto replay_args = std::make_shared<ReplayArgs>();
  CLI::App* replay = slam->add_subcommand(
      "replay",
      "Stream a CARMEN log (FLASER / ROBOTLASER1 lines; plain, .gz or .bz2) into a new session; "
      "write trajectory.txt (TUM), map.svg, map.png and summary.json");
  replay->add_option("LOG", replay_args->log, "CARMEN log file")->required();
  replay->add_flag("--realtime", replay_args->realtime, "Send at the log's pace, not full speed");
  replay->add_option("--out", replay_args->out_dir, "Output folder (default ./out/<log name>)");
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
  registry.Add(replay, [replay_args](CommandContext& c) { return RunSlamReplay(c, *replay_args); });

  auto odometry_args = std::make_shared<OdometryArgs>();
  CLI::App* odometry = slam->add_subcommand(
      "odometry",
      "Write the raw odometry of a CARMEN log's laser lines as a TUM trajectory (no server; the "
      "baseline for `eval relations`)");
  odometry->add_option("LOG", odometry_args->log, "CARMEN log file")->required();
  odometry->add_option("--out", odometry_args->out, "TUM file to write")->required();
  odometry->add_option("--max-scans", odometry_args->max_scans, "Stop after N scans (0 = all)")
      ->check(CLI::NonNegativeNumber);
  registry.Add(odometry,
               [odometry_args](CommandContext& c) { return RunSlamOdometry(c, *odometry_args); });

  auto robot = std::make_shared<std::string>();
  CLI::App* list = slam->add_subcommand("list", "List sessions");
  list->add_option("--robot", *robot, "Only this robot's sessions");
  registry.Add(list, [robot](CommandContext& c) { return RunList(c, *robot); });

  struct SessionArgs {
    std::string session_id;
    std::string out;
  };
  auto map_args = std::make_shared<SessionArgs>();
  CLI::App* map = slam->add_subcommand("map", "Write a session's map.svg, map.png, trajectory.txt");
  map->add_option("SESSION", map_args->session_id, "Session id")->required();
  map->add_option("--out", map_args->out, "Output folder (default ./out/<session>)");
  registry.Add(map, [map_args](CommandContext& c) {
    return RunMap(c, map_args->session_id, map_args->out);
  });

  auto trajectory_args = std::make_shared<SessionArgs>();
  CLI::App* trajectory =
      slam->add_subcommand("trajectory", "Print a session's trajectory (TUM format)");
  trajectory->add_option("SESSION", trajectory_args->session_id, "Session id")->required();
  trajectory->add_option("--out", trajectory_args->out, "Write to FILE instead of stdout");
  registry.Add(trajectory, [trajectory_args](CommandContext& c) {
    return RunTrajectory(c, trajectory_args->session_id, trajectory_args->out);
  });

  auto close_id = std::make_shared<std::string>();
  CLI::App* close = slam->add_subcommand("close", "Close a session (it stays readable)");
  close->add_option("SESSION", *close_id, "Session id")->required();
  registry.Add(close, [close_id](CommandContext& c) { return RunClose(c, *close_id); });
}

}  // namespace waymark::cli
