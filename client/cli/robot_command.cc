// `waymark robot`: a robot (Pioneer + LMS200 on serial ports, or the simulator) streaming into a
// SLAM session, driving the server's suggestions in active mode or the keyboard's in teleop
// mode, recognizing crossings from its camera, with a status line every second.
#include <fmt/format.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "client/devices/camera_source.h"
#include "client/sim/sim_realtime.h"
#include "client/cli/command.h"
#include "client/cli/localize_flags.h"
#include "client/lib/exploration_progress.h"
#include "client/lib/session_resume.h"
#include "client/robot/crossing_watch.h"
#include "client/common/output.h"
#include "client/robot/robot_loop.h"
#include "client/robot/robot_setup.h"
#include "client/common/stop_signals.h"
#include "client/robot/teleop_keys.h"

namespace waymark::cli {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct RobotArgs {
  RobotSetupOptions setup;
  std::string mode = "passive";
  std::string explore = "active";  // the exploration mode behind --mode active
  std::string camera;
  std::string crossings;
  double recognize_every_s = 10;
  double max_linear = 0.3;
  double max_angular = 0.5;
  double duration_s = 0;
  std::string robot_id;
  std::string name;
  std::string resume;
  std::optional<v1::LocalizationConfig> localize;
  bool keep_session = false;
  bool keep_running = false;
  double device_grace_s = 10;
};

std::string DefaultRobotId() {
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) == 0 && host[0] != '\0') return host;
  return "robot";
}

// One status line: where the robot thinks it is, what it does and how its links are.
std::string StatusLine(const RobotStatus& s, const std::optional<CrossingWatch::Result>& crossing,
                       DriveMode mode) {
  std::string line =
      fmt::format("t={:7.1f}s pose=({:6.2f},{:6.2f},{:5.0f}deg) segs={:3d} scans={}/{}",
                  s.device_time, s.pose.x(), s.pose.y(), s.pose.theta() * 180 / kPi, s.segments,
                  s.scans_answered, s.scans_sent);
  if (s.scans_rejected > 0) line += fmt::format(" rejected={}", s.scans_rejected);
  line += fmt::format(" v={:.2f} w={:.2f}", s.linear, s.angular);
  if (mode == DriveMode::kActive && !s.behaviour.empty()) line += " [" + s.behaviour + "]";
  if (s.exploration.state() != v1::ExplorationProgress::STATE_UNSPECIFIED) {
    line += fmt::format(" explore={} open={:.0f}% targets={}",
                        client::ExplorationStateName(s.exploration),
                        100 * s.exploration.open_boundary(), s.exploration.targets_left());
  }
  if (s.server_connected) {
    line += " server=ok";
  } else {
    line += s.reconnects > 0 || !s.server_error.empty() ? " server=DOWN" : " server=connecting";
  }
  if (s.reconnects > 0) line += fmt::format(" reconnects={}", s.reconnects);
  line += s.base_error.empty() ? " base=ok" : " base=ERROR";
  if (s.battery_volts > 0) line += fmt::format(" batt={:.1f}V", s.battery_volts);
  line += s.laser_error.empty() ? " laser=ok" : " laser=ERROR";
  if (crossing && crossing->attempts > 0) line += " crossing=" + crossing->summary;
  return line;
}

// Where exploration stood at the end: the answer that ended it, else the last one.
const v1::ExplorationProgress& FinalExploration(const RobotStatus& s) {
  return client::ExplorationEnded(s.exploration_end) ? s.exploration_end : s.exploration;
}

nlohmann::json SummaryJson(const RobotStatus& s, DriveMode mode, const std::string& devices) {
  nlohmann::json stops = nlohmann::json::object();
  for (int i = 0; i < static_cast<int>(StopReason::kCount); ++i) {
    stops[StopReasonName(static_cast<StopReason>(i))] = s.stops[i];
  }
  const v1::ExplorationProgress& exploration = FinalExploration(s);
  return {{"session_id", s.session_id},
          {"mode", DriveModeName(mode)},
          {"devices", devices},
          {"device_time_s", s.device_time},
          {"pose", {{"x", s.pose.x()}, {"y", s.pose.y()}, {"theta", s.pose.theta()}}},
          {"segments", s.segments},
          {"scans_sent", s.scans_sent},
          {"scans_answered", s.scans_answered},
          {"scans_rejected", s.scans_rejected},
          {"suggestions_driven", s.suggestions_driven},
          {"reconnects", s.reconnects},
          {"safety_stops", stops},
          {"exploration_state", client::ExplorationStateName(exploration)},
          {"exploration_reason", exploration.reason()},
          {"last_server_error", s.server_error},
          {"session_closed", s.session_closed},
          {"close_error", s.close_error}};
}

// Raw keys from a terminal (no echo, no line buffering); restores it on exit. Signals (Ctrl-C)
// still work.
class RawTerminal {
 public:
  RawTerminal() {
    if (!isatty(STDIN_FILENO) || tcgetattr(STDIN_FILENO, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= ~(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
  }
  ~RawTerminal() {
    if (active_) tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }

 private:
  termios saved_{};
  bool active_ = false;
};

// Whether the keyboard may be read: not from a terminal this process runs in the background of
// (`waymark robot ... &`), where reading or setting the terminal would stop the whole process
// (SIGTTIN/SIGTTOU) with its safety watchdog. Input that is not a terminal (a pipe, /dev/null) is
// read: its end only ends the reading (teleop: stops the robot).
bool KeyboardReadable() {
  if (!isatty(STDIN_FILENO)) return true;
  return tcgetpgrp(STDIN_FILENO) == getpgrp();
}

// The exact command that closes a session this run left open (with --server unless it is the
// default).
std::string CloseCommand(const CommandContext& context, const std::string& session_id) {
  const std::string server = context.globals.server == GlobalOptions{}.server
                                 ? ""
                                 : " --server " + context.globals.server;
  return fmt::format("waymark{} slam close {}", server, session_id);
}

// How the final line names the session's state: closed, left open as asked, or still open
// because the close failed (the server gone): then how to close it.
std::string SessionEnd(const CommandContext& context, const RobotStatus& s, bool keep_session) {
  if (s.session_closed) return "closed";
  if (keep_session) return "left open; continue it with --resume " + s.session_id;
  return fmt::format("STILL OPEN: could not close it ({}); close it with `{}`", s.close_error,
                     CloseCommand(context, s.session_id));
}

int RunRobot(CommandContext& context, RobotArgs args) {
  DriveMode mode = DriveMode::kPassive;
  if (args.mode == "active") mode = DriveMode::kActive;
  if (args.mode == "teleop") mode = DriveMode::kTeleop;
  if (args.camera.empty() != args.crossings.empty()) {
    return ReportError(
        context, absl::InvalidArgumentError("--camera and --crossings go together: frames from the "
                                            "camera are recognized against the crossing database"));
  }
  std::ostream& lines = context.globals.json ? context.err : context.out;
  // Status, events, crossing answers and teleop notes come from four threads: one line at a time.
  std::mutex lines_mutex;
  auto say = [&](const std::string& line) {
    std::lock_guard<std::mutex> lock(lines_mutex);
    lines << line << "\n" << std::flush;
  };

  // The camera is opened before the robot: a wrong camera must not leave a robot connected.
  std::unique_ptr<client::CrossingClient> crossing_client;
  std::unique_ptr<client::CameraSource> camera;
  if (!args.camera.empty()) {
    crossing_client = context.Connect();
    client::CameraSourceOptions camera_options;
    // Send no more pixels than the database works at.
    auto databases = crossing_client->ListDatabases();
    if (!databases.ok()) return ReportError(context, databases.status(), "--crossings");
    bool found = false;
    for (const v1::CrossingDatabase& db : databases->databases()) {
      if (db.name() != args.crossings) continue;
      found = true;
      if (db.params().has_work_width()) camera_options.width = db.params().work_width();
      if (db.params().has_work_height()) camera_options.height = db.params().work_height();
    }
    if (!found) {
      return ReportError(context,
                         absl::NotFoundError(fmt::format("crossing database '{}' not found on {}",
                                                         args.crossings, context.globals.server)));
    }
    auto opened = client::CameraSource::Open(args.camera, camera_options);
    if (!opened.ok()) return ReportError(context, opened.status(), args.camera);
    camera = *std::move(opened);
  }

  auto devices = OpenRobotDevices(args.setup);
  if (!devices.ok()) return ReportError(context, devices.status());
  say("robot: " + devices->description);

  RobotLoopOptions options;
  options.mode = mode;
  options.exploration = args.explore == "frontier" ? v1::ExplorationConfig::FRONTIER
                        : args.explore == "wander" ? v1::ExplorationConfig::WANDER
                                                   : v1::ExplorationConfig::ACTIVE;
  options.robot_id = args.robot_id.empty() ? DefaultRobotId() : args.robot_id;
  options.session_name = args.name;
  options.resume_session_id = args.resume;
  options.localize = args.localize;
  options.limits = {args.max_linear, args.max_angular};
  options.duration_s = args.duration_s;
  options.time_scale = devices->time_scale;
  options.close_session = !args.keep_session;
  options.keep_running = args.keep_running;
  options.device_grace = absl::Seconds(args.device_grace_s);
  if (context.globals.timeout_s > 0) {
    options.answer_timeout = absl::Seconds(std::min(context.globals.timeout_s, 5.0));
  }

  auto slam = context.ConnectSlam();
  RobotLoop loop(*slam, *devices->base, *devices->laser, options);
  StopSignals signals;
  std::unique_ptr<CrossingWatch> watch;
  if (camera) {
    watch = std::make_unique<CrossingWatch>(*crossing_client, std::move(camera), args.crossings,
                                            args.recognize_every_s, say);
  }
  loop.set_event_callback(say);
  loop.set_status_callback([&](const RobotStatus& s) {
    if (watch && signals.TakeRecognizeRequest()) watch->Request();
    std::optional<CrossingWatch::Result> crossing;
    if (watch) crossing = watch->last();
    say(StatusLine(s, crossing, mode));
  });

  // The keyboard in every mode: q quits, c recognizes; teleop drives with it too.
  std::thread keys;
  std::optional<RawTerminal> terminal;
  if (!KeyboardReadable()) {
    if (mode == DriveMode::kTeleop) say("teleop: no keyboard (running in the background)");
  } else {
    terminal.emplace();
    say(KeysHelp(mode == DriveMode::kTeleop));
    KeyboardHooks hooks;
    hooks.quit = [&] { signals.RequestStop(); };
    if (watch) hooks.recognize = [&] { watch->Request(); };
    if (mode == DriveMode::kTeleop) {
      hooks.drive = [&](double linear, double angular) { return loop.Teleop(linear, angular); };
      hooks.base_stopped = [&] {
        const RobotStatus s = loop.status();
        return s.linear == 0 && s.angular == 0;
      };
    }
    hooks.say = say;
    keys = std::thread([&, hooks] {
      ReadKeys(STDIN_FILENO, signals.stop_requested(), options.limits, hooks);
    });
  }
  auto result = loop.Run(signals.stop_requested());
  signals.RequestStop();  // ends the key thread
  if (keys.joinable()) keys.join();
  terminal.reset();
  watch.reset();
  if (!result.ok()) {
    const int code = ReportError(context, result.status(), "robot");
    // The run ended without closing its session: say so, and how to close or continue it.
    const std::string session_id = loop.status().session_id;
    if (!session_id.empty() && !client::SessionIsGone(result.status())) {
      context.err << fmt::format(
          "session {} is still open: continue it with `waymark robot ... --resume {}` or close "
          "it with `{}`\n",
          session_id, session_id, CloseCommand(context, session_id));
    }
    return code;
  }
  nlohmann::json summary = SummaryJson(*result, mode, devices->description);
  if (devices->sim) {
    const adapters::BasePose truth = devices->sim->true_pose();
    summary["sim"] = {{"collisions", devices->sim->collisions()},
                      {"distance_m", devices->sim->distance_travelled()},
                      {"true_pose", {{"x", truth.x}, {"y", truth.y}, {"theta", truth.theta}}}};
  }
  if (!result->session_closed && !args.keep_session) {
    summary["close_command"] = CloseCommand(context, result->session_id);
  }
  if (context.globals.json) {
    PrintJson(context.out, summary);
    if (!result->session_closed && !args.keep_session) {
      context.err << fmt::format("session {} is STILL OPEN: could not close it ({}); close it "
                                 "with `{}`\n",
                                 result->session_id, result->close_error,
                                 CloseCommand(context, result->session_id));
    }
  } else {
    lines << fmt::format(
        "stopped: session {} ({}), {} scans answered, {} reconnects{}\n", result->session_id,
        SessionEnd(context, *result, args.keep_session), result->scans_answered,
        result->reconnects,
        client::ExplorationEnded(result->exploration_end)
            ? ", exploration " + client::ExplorationStateName(result->exploration_end)
            : "");
  }
  // DONE is the success of an exploration run; STUCK has its own code so a script can tell a
  // robot that gave up from one that finished.
  return result->exploration_end.state() == v1::ExplorationProgress::STUCK ? kExitExplorationStuck
                                                                           : kExitOk;
}

}  // namespace

void AddRobotCommand(CLI::App& app, CommandRegistry& registry) {
  auto args = std::make_shared<RobotArgs>();
  CLI::App* robot = app.add_subcommand(
      "robot",
      "Run a robot against the server: stream its laser and odometry into a SLAM session, drive "
      "the server's suggestions (--mode active) or the keyboard (--mode teleop), recognize "
      "crossings from its camera. Ctrl-C or q (in every mode) stops the robot, closes the "
      "session, then exits; when the session cannot be closed (the server gone) the last line "
      "says it is still open and how to close it. Active mode ends by itself when the server "
      "says exploration is DONE (exit code 0) or STUCK (exit code 3).");
  robot
      ->add_option("--base", args->setup.base,
                   "serial:DEVICE (Pioneer over ARCOS/P2OS, e.g. serial:/dev/ttyS0) or "
                   "sim:WORLD (simulator: a built-in world, see `sim worlds`, or a world file)")
      ->required();
  robot
      ->add_option("--laser", args->setup.laser,
                   "serial:DEVICE (SICK LMS200, e.g. serial:/dev/ttyUSB0) or sim")
      ->required();
  robot
      ->add_option("--mode", args->mode,
                   "passive: stream only; active: drive the server's "
                   "suggestions; teleop: drive with the keyboard")
      ->check(CLI::IsMember({"passive", "active", "teleop"}))
      ->capture_default_str();
  robot
      ->add_option("--explore", args->explore,
                   "With --mode active, who chooses where to go: active (the goal layer over the "
                   "paper's planner), frontier (nearest frontier) or wander (the paper's "
                   "baseline); see docs/exploration.md")
      ->check(CLI::IsMember({"active", "frontier", "wander"}))
      ->capture_default_str();
  robot->add_option("--camera", args->camera,
                    "Camera for crossing recognition: device index, video file, stream URL or "
                    "image pattern (needs --crossings)");
  robot->add_option("--crossings", args->crossings, "Crossing database to recognize against");
  robot
      ->add_option("--recognize-every", args->recognize_every_s,
                   "Seconds between recognitions (0 = only on request: key c in teleop, "
                   "SIGUSR1)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  robot->add_option("--max-linear", args->max_linear, "Velocity clamp (m/s)")
      ->check(CLI::Range(0.0, 2.0))
      ->capture_default_str();
  robot->add_option("--max-angular", args->max_angular, "Turn rate clamp (rad/s)")
      ->check(CLI::Range(0.0, 4.0))
      ->capture_default_str();
  robot
      ->add_option("--duration", args->duration_s,
                   "Stop after this many seconds of the robot's clock (0 = Ctrl-C or q): wall "
                   "seconds on a real robot, simulated seconds with the simulator (at "
                   "--sim-speed 10, --duration 60 takes 6 s)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  robot->add_option("--robot-id", args->robot_id, "Robot id for the session (default: hostname)");
  robot->add_option("--name", args->name, "Session name");
  CLI::Option* resume = robot->add_option("--resume", args->resume,
                                          "Stream into this open session instead of a new one");
  AddLocalizeFlags(robot, &args->localize)->excludes(resume);
  robot->add_flag("--keep-session", args->keep_session,
                  "Leave the session open at exit (resume it later with --resume)");
  robot->add_flag("--keep-running", args->keep_running,
                  "Active mode: at DONE or STUCK stop the robot but keep running (streaming, "
                  "session open) until Ctrl-C instead of exiting");
  robot
      ->add_option("--device-grace", args->device_grace_s,
                   "Seconds a base or laser may stay away (unplugged cable) before the run ends; "
                   "the robot stands still meanwhile and serial devices reconnect by themselves")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  robot
      ->add_option("--base-baud", args->setup.base_baud,
                   "Pioneer serial rate (ARCOS: 9600; 19200, 38400, 57600, 115200 if configured)")
      ->check(CLI::IsMember({9600, 19200, 38400, 57600, 115200}))
      ->capture_default_str();
  robot
      ->add_option("--laser-baud", args->setup.laser_baud,
                   "LMS200 rate to switch to (9600, 19200, 38400, 500000)")
      ->check(CLI::IsMember({9600, 19200, 38400, 500000}))
      ->capture_default_str();
  robot->add_flag("--half-degree", args->setup.half_degree,
                  "LMS200 0.5-degree mode (361 beams) instead of 1 degree (181)");
  robot
      ->add_option("--sim-speed", args->setup.sim_speed,
                   "Simulator: simulated seconds per wall second")
      ->check(CLI::Range(0.01, 1000.0))
      ->capture_default_str();
  robot->add_option("--seed", args->setup.seed, "Simulator seed")->capture_default_str();
  registry.Add(robot, [args](CommandContext& context) { return RunRobot(context, *args); });
}

}  // namespace waymark::cli
