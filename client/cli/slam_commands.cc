// `waymark slam ...`: laser SLAM sessions. replay and odometry live in slam_replay.cc; the small
// session commands (list, map, trajectory, close, delete) here.
#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"
#include "client/common/stop_signals.h"
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
  const SlamOutTarget target = SlamOutTargetOf(
      out.empty() ? std::filesystem::path("out") / session_id : std::filesystem::path(out));
  auto written = WriteSlamOutputs(
      target, *map, *trajectory,
      fmt::format("session {}: {} segments", session_id, map->segments_size()));
  if (!written.ok()) return ReportError(context, written.status(), target.path.string());
  if (context.globals.json) {
    nlohmann::json files = nlohmann::json::array();
    for (const auto& file : *written) files.push_back(file.string());
    PrintJson(context.out, {{"session_id", session_id},
                            {"segments", map->segments_size()},
                            {"map_revision", map->map_revision()},
                            {"trajectory_poses", trajectory->poses_size()},
                            {target.is_folder() ? "out_dir" : "out", target.path.string()},
                            {"files", files}});
  } else {
    context.out << fmt::format("{} segments (revision {}), {} poses: wrote {}\n",
                               map->segments_size(), map->map_revision(),
                               trajectory->poses_size(), DescribeWritten(*written));
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

}  // namespace

void AddSlamCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* slam = app.add_subcommand("slam", "Laser SLAM sessions");
  slam->require_subcommand(1);

  auto replay_args = std::make_shared<ReplayArgs>();
  CLI::App* replay = slam->add_subcommand(
      "replay",
      "Stream a CARMEN log (FLASER / ROBOTLASER1 lines; plain, .gz or .bz2) into a new session, "
      "close it, and write trajectory.txt (TUM), map.svg, map.png and summary.json. A log whose "
      "stamps are broken (most lines skipped) is reported and exits 1: use --restamp. Ctrl-C stops "
      "early: the session is closed and the outputs written, marked partial (exit 130)");
  replay->add_option("LOG", replay_args->log, "CARMEN log file")->required();
  replay->add_flag("--realtime", replay_args->realtime, "Send at the log's pace, not full speed");
  AddRestampFlags(replay, &replay_args->restamp, &replay_args->rate_hz);
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
  registry.Add(replay, [replay_args](CommandContext& c) {
    StopSignals signals;  // Ctrl-C: stop sending, close the session, write partial outputs
    return RunSlamReplay(c, *replay_args, [&signals] { return signals.stop_requested().load(); });
  });

  auto odometry_args = std::make_shared<OdometryArgs>();
  CLI::App* odometry = slam->add_subcommand(
      "odometry",
      "Write the raw odometry of a CARMEN log's laser lines as a TUM trajectory (no server; the "
      "baseline for `eval relations`); broken stamps are reported and exit 1, as in replay");
  odometry->add_option("LOG", odometry_args->log, "CARMEN log file")->required();
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

  struct SessionArgs {
    std::string session_id;
    std::string out;
  };
  auto map_args = std::make_shared<SessionArgs>();
  CLI::App* map = slam->add_subcommand("map", "Write a session's map.svg, map.png, trajectory.txt");
  map->add_option("SESSION", map_args->session_id, "Session id")->required();
  map->add_option("--out", map_args->out,
                  "Output folder (default ./out/<session>); a path ending in .svg or .png writes "
                  "only that picture");
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
