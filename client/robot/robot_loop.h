#ifndef WAYMARK_CLIENT_ROBOT_ROBOT_LOOP_H_
#define WAYMARK_CLIENT_ROBOT_ROBOT_LOOP_H_

// The robot side of a SLAM session (`waymark robot`): reads the laser and the base, streams scans
// and odometry into a session, and in active mode drives the server's suggested controls with the
// paper's go-stop protocol (stop, scan, wait for the answer, hold the suggestion for its
// duration, repeat). The devices are the interfaces of robot_devices.h, so the same loop drives
// the Pioneer + LMS200 over serial ports and the simulator.
//
// Safety: every motor command goes through a SafetyGuard (clamps, watchdog). The base stops when
// the server stream breaks or stops answering, when a suggestion is older than its duration, on
// bumpers or a wheel stall, when a device stops reporting, and before the loop returns. A broken
// stream is reopened on the same session with exponential backoff; the session resumes where it
// was (the server reloads it from its checkpoint after a restart).
//
// End of exploration: in active mode, an answer whose exploration state (goal layer sessions) is
// DONE or STUCK stops the base and ends the run like its duration would (the session is closed
// unless close_session is false); RobotStatus.exploration_end says which. With keep_running the
// loop stays connected instead, the robot standing and its scans still streamed, until `stop`.

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/devices/robot_devices.h"
#include "client/lib/slam_client.h"
#include "client/robot/safety_guard.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

enum class DriveMode {
  kPassive,  // stream only; the robot does not move on its own
  kActive,   // drive the server's suggestions (exploration mode ACTIVE)
  kTeleop,   // stream, and drive what Teleop() is given (keyboard)
};
const char* DriveModeName(DriveMode mode);

struct RobotLoopOptions {
  DriveMode mode = DriveMode::kPassive;
  std::string robot_id = "robot";
  std::string session_name;       // default "<robot_id> <mode>"
  std::string resume_session_id;  // attach to this open session instead of creating one
  v1::ExplorationConfig::Mode exploration = v1::ExplorationConfig::ACTIVE;  // for kActive
  // Set: the session created localizes on this stored map instead of mapping (not with resume).
  std::optional<v1::LocalizationConfig> localize;
  VelocityLimits limits;
  // Device seconds to run (the base's clock: simulated seconds with the simulator, so at
  // time_scale 10 a duration of 60 takes 6 s of wall time); 0 = until `stop` is set.
  double duration_s = 0;
  double time_scale = 1.0;  // device seconds per wall second (the simulator's speed)
  // A scan not answered within this counts as a broken stream (the base stops, then reconnect).
  absl::Duration answer_timeout = absl::Seconds(5);
  absl::Duration reconnect_initial = absl::Milliseconds(500);
  absl::Duration reconnect_max = absl::Seconds(10);
  // A device that keeps failing for this long (device seconds of wall time) ends the run.
  absl::Duration device_grace = absl::Seconds(5);
  double odometry_period = 0.1;  // device s between odometry messages during a hold
  double settle_s = 0.1;         // go-stop: time to come to rest before the scan (paper: 0.1 s)
  double teleop_hold = 0.5;      // device s a teleop command stays valid without a repeat
  int passive_window = 8;        // scans in flight in passive/teleop mode
  absl::Duration status_period = absl::Seconds(1);  // wall clock
  bool close_session = true;                        // close the session when the run ends
  // Active: after DONE or STUCK, keep streaming with the robot stopped until `stop` is set
  // instead of ending the run.
  bool keep_running = false;
};

// What a status line shows; also the run's summary.
struct RobotStatus {
  std::string session_id;
  double device_time = 0;  // seconds since the run started
  v1::Pose2D pose;         // latest SLAM estimate (map frame)
  int segments = 0;
  uint64_t scans_sent = 0;
  uint64_t scans_answered = 0;
  uint64_t scans_rejected = 0;  // messages the server refused (scans or odometry)
  std::string last_rejection;
  uint64_t reconnects = 0;
  // The current stream has answered a scan. A stream reopened while the server is down exists
  // but has not: the link is not up until the server answers.
  bool server_connected = false;
  std::string server_error;  // why the last stream ended
  std::string base_error;    // empty while the base reports
  std::string laser_error;
  double battery_volts = 0;  // last reported by the base; 0 = not reported
  double linear = 0;         // commanded
  double angular = 0;
  std::string behaviour;  // of the suggestion being driven (active mode)
  // The last answered scan's exploration progress (goal layer sessions; state unset otherwise).
  v1::ExplorationProgress exploration;
  // Active mode: the answer that ended exploration (DONE or STUCK) and stopped the robot; state
  // unset while it goes on.
  v1::ExplorationProgress exploration_end;
  uint64_t suggestions_driven = 0;
  uint64_t stops[static_cast<int>(StopReason::kCount)] = {};
  // The run closed its session at the end. False when asked not to (close_session false), when
  // the run ended in an error, or when the close failed (close_error says why: the server is
  // gone, say): the session is then still open on the server.
  bool session_closed = false;
  std::string close_error;
};

class RobotLoop {
 public:
  using StatusCallback = std::function<void(const RobotStatus&)>;
  using EventCallback = std::function<void(const std::string&)>;

  RobotLoop(client::SlamClient& client, adapters::MobileBase& base, adapters::LaserScanner& laser,
            RobotLoopOptions options);
  ~RobotLoop();

  void set_status_callback(StatusCallback callback) { on_status_ = std::move(callback); }
  void set_event_callback(EventCallback callback) { on_event_ = std::move(callback); }

  // Runs until the duration is reached, `stop` is set or (active mode, without keep_running)
  // exploration is DONE or STUCK; the base is stopped on return. Errors:
  // the session cannot be created/resumed, a device keeps failing, the session is not in a mode
  // that suggests controls (active), or the session is gone on the server.
  absl::StatusOr<RobotStatus> Run(const std::atomic<bool>& stop);

  // Teleop: drive (linear, angular) for teleop_hold seconds; safe from any thread.
  absl::Status Teleop(double linear, double angular);

  RobotStatus status() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
  StatusCallback on_status_;
  EventCallback on_event_;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_ROBOT_LOOP_H_
