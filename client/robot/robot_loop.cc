#include "client/robot/robot_loop.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "client/common/steady_clock.h"
#include "client/lib/exploration_progress.h"
#include "client/lib/session_resume.h"
#include "client/robot/laser_session.h"

namespace waymark::cli {
namespace {

// A status as an event shows it: code and message (without the payload that marks calls).
std::string Text(const absl::Status& status) {
  return status.ToString(absl::StatusToStringMode::kWithNoExtraData);
}

// Sleeps `seconds` of wall time in short slices, returning early once `stop` is set.
void SleepUnlessStopped(double seconds, const std::atomic<bool>& stop) {
  const double end = adapters::SteadySeconds() + seconds;
  while (!stop.load()) {
    const double left = end - adapters::SteadySeconds();
    if (left <= 0) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(left, 0.05)));
  }
}

// Remembers when a device started failing; the run ends when it keeps failing past the grace.
class DeviceHealth {
 public:
  explicit DeviceHealth(absl::Duration grace) : grace_s_(absl::ToDoubleSeconds(grace)) {}
  void Ok() { failing_since_.reset(); }
  // True when the failure has lasted past the grace.
  bool Fail() {
    if (!failing_since_) failing_since_ = adapters::SteadySeconds();
    return adapters::SteadySeconds() - *failing_since_ > grace_s_;
  }

 private:
  double grace_s_;
  std::optional<double> failing_since_;
};

}  // namespace

const char* DriveModeName(DriveMode mode) {
  switch (mode) {
    case DriveMode::kPassive:
      return "passive";
    case DriveMode::kActive:
      return "active";
    case DriveMode::kTeleop:
      return "teleop";
  }
  return "unknown";
}

class RobotLoop::Impl {
 public:
  Impl(client::SlamClient& client, adapters::MobileBase& base, adapters::LaserScanner& laser,
       RobotLoopOptions options)
      : client_(client),
        base_(base),
        laser_(laser),
        options_(std::move(options)),
        guard_(base, options_.limits, options_.time_scale),
        base_health_(options_.device_grace),
        laser_health_(options_.device_grace) {}

  absl::StatusOr<RobotStatus> Run(const std::atomic<bool>& stop, const StatusCallback& on_status,
                                  const EventCallback& on_event) {
    on_event_ = on_event;
    on_status_ = on_status;
    if (absl::Status s = OpenSession(); !s.ok()) return s;
    absl::Status result = absl::OkStatus();
    double backoff = absl::ToDoubleSeconds(options_.reconnect_initial);
    while (!stop.load() && !DurationReached() && !(explored_ && !options_.keep_running)) {
      if (!stream_) OpenStream();
      // Explored and kept running: the robot stands and streams, as in passive mode.
      absl::Status step =
          options_.mode == DriveMode::kActive && !explored_ ? ActiveStep(stop) : PassiveStep();
      if (!step.ok()) {
        result = step;
        break;
      }
      if (!stream_) {
        // The stream broke during the step: the base is already stopped. Back off, then reopen.
        if (!session_gone_.ok()) {
          result = session_gone_;
          break;
        }
        Event(fmt::format("reconnecting within {:.1f} s", backoff));
        WaitForServer(backoff, stop);
        // A session changing servers (refused with its owner's address, or its owner gone) is
        // served again as soon as the old lease expires: keep trying at the first pace rather
        // than backing off past the lease, as for a server that is down.
        backoff = handing_over_
                      ? absl::ToDoubleSeconds(options_.reconnect_initial)
                      : std::min(2 * backoff, absl::ToDoubleSeconds(options_.reconnect_max));
        std::lock_guard<std::mutex> lock(mutex_);
        ++reconnects_;
      } else if (answered_since_open_) {
        backoff = absl::ToDoubleSeconds(options_.reconnect_initial);
      }
      ReportWarnings();
      MaybeReportStatus();
    }
    guard_.Halt(StopReason::kShutdown).IgnoreError();
    FinishStream(/*cancel=*/!result.ok());
    std::string close_error;
    bool closed_now = false;
    if (result.ok() && options_.close_session) {
      auto closed = client_.CloseSession(session_id_);
      closed_now = closed.ok();
      if (!closed.ok()) {
        close_error = Text(closed.status());
        Event(fmt::format("could not close session {}: {}: it is still open on the server",
                          session_id_, close_error));
      }
    }
    if (!result.ok()) return result;
    RobotStatus final_status = Snapshot();
    final_status.session_closed = closed_now;
    final_status.close_error = close_error;
    return final_status;
  }

  absl::Status Teleop(double linear, double angular) {
    if (options_.mode != DriveMode::kTeleop) {
      return absl::FailedPreconditionError("teleop commands need --mode teleop");
    }
    return guard_.Drive(linear, angular, options_.teleop_hold);
  }

  RobotStatus Snapshot() const {
    std::lock_guard<std::mutex> lock(mutex_);
    RobotStatus s = status_;
    s.session_id = session_id_;
    s.device_time = start_stamp_ ? last_base_stamp_ - *start_stamp_ : 0;
    s.reconnects = reconnects_;
    s.server_connected = stream_ != nullptr && answered_since_open_ && !stream_->ended();
    s.linear = guard_.commanded_linear();
    s.angular = guard_.commanded_angular();
    s.suggestions_driven = suggestions_driven_;
    for (int i = 0; i < static_cast<int>(StopReason::kCount); ++i) {
      s.stops[i] = guard_.stops(static_cast<StopReason>(i));
    }
    if (stream_) {
      const client::SensorStream::Stats stats = stream_->stats();
      s.scans_sent = scans_sent_before_ + stats.scans_sent;
    } else {
      s.scans_sent = scans_sent_before_;
    }
    return s;
  }

 private:
  void Event(const std::string& message) {
    if (on_event_) on_event_(message);
  }

  // Waits up to `seconds` for the server to accept connections again, returning as soon as it
  // does: after a restart gRPC would otherwise keep failing calls until its own reconnect backoff
  // ends (seconds). (A stream opened with wait_for_ready would block the loop's sends instead.)
  // A server that is up and refused the stream (another stream still attached, say) gets the
  // whole backoff: retrying at once would hammer it.
  void WaitForServer(double seconds, const std::atomic<bool>& stop) {
    if (client_.WaitForConnected(absl::ZeroDuration())) {
      SleepUnlessStopped(seconds, stop);
      return;
    }
    client_.ResetConnectBackoff();
    const double end = adapters::SteadySeconds() + seconds;
    while (!stop.load() && adapters::SteadySeconds() < end) {
      if (client_.WaitForConnected(absl::Seconds(std::min(0.05, end - adapters::SteadySeconds()))))
        return;
    }
  }

  // Warnings found on the stream's reader thread, told on the loop's (where events come from).
  void ReportWarnings() {
    std::vector<std::string> warnings;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      warnings.swap(pending_warnings_);
    }
    for (const std::string& warning : warnings) Event(warning);
  }

  // Every status_period of wall time, also in the middle of a hold.
  void MaybeReportStatus() {
    if (!on_status_ || adapters::SteadySeconds() < next_status_) return;
    on_status_(Snapshot());
    next_status_ = adapters::SteadySeconds() + absl::ToDoubleSeconds(options_.status_period);
  }

  double RemainingDeviceTime() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (options_.duration_s <= 0 || !start_stamp_) return 1e300;
    return options_.duration_s - (last_base_stamp_ - *start_stamp_);
  }

  bool DurationReached() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return options_.duration_s > 0 && start_stamp_ &&
           last_base_stamp_ - *start_stamp_ >= options_.duration_s - 1e-9;
  }

  absl::Status OpenSession() {
    if (!options_.resume_session_id.empty()) {
      session_id_ = options_.resume_session_id;
      Event(fmt::format("resuming session {}", session_id_));
      return absl::OkStatus();
    }
    v1::CreateSessionRequest request = LaserSessionRequest(
        laser_.layout(), options_.robot_id,
        !options_.session_name.empty()
            ? options_.session_name
            : fmt::format("{} {}", options_.robot_id, DriveModeName(options_.mode)),
        options_.mode == DriveMode::kActive ? options_.exploration
                                            : v1::ExplorationConfig::PASSIVE);
    if (options_.localize) *request.mutable_laser()->mutable_localize() = *options_.localize;
    auto session = client_.CreateSession(request);
    if (!session.ok()) return session.status();
    session_id_ = session->session_id();
    Event(options_.localize ? fmt::format("session {} created, localizing on map {}", session_id_,
                                          options_.localize->map_session_id())
                            : fmt::format("session {} created", session_id_));
    return absl::OkStatus();
  }

  void OpenStream() {
    const int window = options_.mode == DriveMode::kActive ? 1 : options_.passive_window;
    auto stream = client_.StreamSensorData(session_id_, window,
                                           [this](const v1::SlamUpdate& u) { OnUpdate(u); });
    stream->set_answer_timeout(options_.answer_timeout);
    closing_ = false;
    end_seen_ = false;
    // The motors stop the moment the stream ends, not at the loop's next send.
    stream->set_end_callback([this] {
      if (!closing_.load() && !end_seen_.exchange(true)) {
        guard_.Halt(StopReason::kStreamBroken).IgnoreError();
      }
    });
    std::lock_guard<std::mutex> lock(mutex_);
    stream_ = std::move(stream);
    answered_since_open_ = false;
  }

  void OnUpdate(const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(mutex_);
    answered_since_open_ = true;  // a rejection too: the server is there
    // A reopened stream's first answer says what the session held when it attached: less than
    // this robot had answered means the server lost it (resumed from an old checkpoint).
    if (update.has_stream_start()) {
      if (std::optional<std::string> warning = client::ResumeWarning(
              session_id_, answered_progress_, update.stream_start(), "scans",
              "this robot's stream", "the map and the pose restart from there")) {
        pending_warnings_.push_back(*std::move(warning));
      }
    }
    answered_progress_.Observe(update);
    if (update.has_rejection()) {
      ++status_.scans_rejected;
      status_.last_rejection = update.rejection().message();
      last_rejected_ = true;
      return;
    }
    last_rejected_ = false;
    ++status_.scans_answered;
    status_.pose = update.pose();
    status_.segments = update.segments();
    status_.exploration = update.exploration();
    latest_ = update;
  }

  // Ends the current stream: the base stops first, then the stream is cancelled (or, at the end
  // of a good run, half-closed so the server answers what it holds).
  absl::Status FinishStream(bool cancel) {
    std::unique_ptr<client::SensorStream> stream;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stream = std::move(stream_);
    }
    if (!stream) return absl::OkStatus();
    closing_ = true;  // our own cancel or half-close is not a break
    if (cancel) stream->Cancel();
    absl::Status finished = stream->Finish();
    std::lock_guard<std::mutex> lock(mutex_);
    scans_sent_before_ += stream->stats().scans_sent;
    handing_over_ = !finished.ok() &&
                    (!stream->session_owner().empty() || !stream->routed_to().empty());
    if (!finished.ok()) {
      status_.server_error = Text(finished);
      if (client::SessionIsGone(finished)) session_gone_ = finished;
    }
    return finished;
  }

  void StreamBroke(const absl::Status& why) {
    // The end callback may have stopped the base already; count the break once.
    if (!end_seen_.exchange(true)) guard_.Halt(StopReason::kStreamBroken).IgnoreError();
    // A stream the server ended explains itself in Finish(); one that hangs must be cancelled.
    const bool cancel = why.code() != absl::StatusCode::kUnavailable;
    const absl::Status finished = FinishStream(cancel);
    // After our own cancel, Finish() says only CANCELLED: the reason is `why`.
    Event(fmt::format("server stream broken ({}): base stopped",
                      cancel || finished.ok() ? Text(why) : Text(finished)));
  }

  // A failed device read: the base stops at once (a robot that cannot see or feel its wheels must
  // not move); the run ends once the device has failed for longer than the grace.
  void DeviceFailed(const char* device, const absl::Status& error, std::string& error_field,
                    DeviceHealth& health, absl::Status& fatal) {
    guard_.Halt(StopReason::kDeviceError).IgnoreError();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      error_field = Text(error);
    }
    if (health.Fail()) {
      fatal = absl::UnavailableError(
          fmt::format("the {} stopped reporting: {}", device, Text(error)));
    }
  }

  // Reads the base; stops it on bumpers or a stall. nullopt when the read failed (and the run
  // goes on unless the base keeps failing, reported through `fatal`).
  std::optional<adapters::BaseState> ReadBase(absl::Status& fatal) {
    absl::StatusOr<adapters::BaseState> state = base_.Read();
    if (!state.ok()) {
      DeviceFailed("base", state.status(), status_.base_error, base_health_, fatal);
      return std::nullopt;
    }
    base_health_.Ok();
    if (state->bumped && guard_.moving()) {
      guard_.Halt(StopReason::kBumper).IgnoreError();
      Event("bumper pressed: base stopped");
    }
    if (state->stalled && guard_.moving()) {
      guard_.Halt(StopReason::kStall).IgnoreError();
      Event("wheel stalled: base stopped");
    }
    std::lock_guard<std::mutex> lock(mutex_);
    status_.base_error.clear();
    status_.battery_volts = state->battery_volts;
    if (!start_stamp_) start_stamp_ = state->stamp;
    last_base_stamp_ = std::max(last_base_stamp_, state->stamp);
    return *std::move(state);
  }

  std::optional<adapters::LaserReading> ReadLaser(absl::Status& fatal) {
    absl::StatusOr<adapters::LaserReading> reading = laser_.Read();
    if (!reading.ok()) {
      DeviceFailed("laser", reading.status(), status_.laser_error, laser_health_, fatal);
      return std::nullopt;
    }
    laser_health_.Ok();
    std::lock_guard<std::mutex> lock(mutex_);
    status_.laser_error.clear();
    return *std::move(reading);
  }

  // Odometry only when its stamp moved on: the server refuses stamps that do not increase.
  absl::Status SendOdometry(const adapters::BaseState& state) {
    if (!stream_ || state.stamp <= last_odometry_stamp_) return absl::OkStatus();
    v1::Odometry odometry;
    odometry.set_stamp(state.stamp);
    *odometry.mutable_pose() = ToProto(state.odometry);
    last_odometry_stamp_ = state.stamp;
    return stream_->SendOdometry(odometry);
  }

  absl::Status SendScan(const adapters::LaserReading& reading) {
    if (!stream_ || reading.stamp <= last_scan_stamp_) return absl::OkStatus();
    v1::LaserScan scan;
    scan.set_stamp(reading.stamp);
    scan.mutable_ranges()->Assign(reading.ranges.begin(), reading.ranges.end());
    last_scan_stamp_ = reading.stamp;
    return stream_->SendScan(scan);
  }

  // Passive and teleop: every scan with the odometry read right after it (the server
  // interpolates odometry at the scan's stamp).
  absl::Status PassiveStep() {
    absl::Status fatal;
    std::optional<adapters::LaserReading> reading = ReadLaser(fatal);
    if (!fatal.ok()) return fatal;
    std::optional<adapters::BaseState> state = ReadBase(fatal);
    if (!fatal.ok()) return fatal;
    if (!stream_) return absl::OkStatus();
    absl::Status sent = state ? SendOdometry(*state) : absl::OkStatus();
    if (sent.ok() && reading) sent = SendScan(*reading);
    if (sent.ok() && stream_->ended()) sent = absl::UnavailableError("the server ended the stream");
    if (!sent.ok()) StreamBroke(sent);
    return absl::OkStatus();
  }

  // Active: the go-stop protocol. The base is at rest here (the previous hold ended with a stop).
  absl::Status ActiveStep(const std::atomic<bool>& stop) {
    absl::Status fatal;
    SleepUnlessStopped(options_.settle_s / options_.time_scale, stop);
    std::optional<adapters::LaserReading> reading = ReadLaser(fatal);
    if (!fatal.ok()) return fatal;
    std::optional<adapters::BaseState> state = ReadBase(fatal);
    if (!fatal.ok()) return fatal;
    if (!reading || !state || !stream_) return absl::OkStatus();
    absl::Status sent = SendOdometry(*state);
    if (sent.ok()) sent = SendScan(*reading);
    if (sent.ok()) sent = stream_->WaitIdle(options_.answer_timeout);
    if (!sent.ok()) {
      StreamBroke(sent);
      return absl::OkStatus();
    }
    v1::SuggestedControl control;
    v1::ExplorationProgress progress;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (last_rejected_) return absl::OkStatus();  // counted; scan again
      control = latest_.suggestion();
      progress = latest_.exploration();
    }
    if (client::ExplorationEnded(progress)) return EndExploration(progress);
    if (control.behaviour() == v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED) {
      return absl::FailedPreconditionError(fmt::format(
          "session {} suggests no controls: it is not in active or wander exploration mode "
          "(create a new session with --mode active)",
          session_id_));
    }
    // The last hold ends with the run.
    const double hold =
        std::min(control.duration() > 0 ? control.duration() : options_.odometry_period,
                 std::max(options_.odometry_period, RemainingDeviceTime()));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status_.behaviour =
          absl::AsciiStrToLower(v1::SuggestedControl::Behaviour_Name(control.behaviour()));
      ++suggestions_driven_;
    }
    if (absl::Status s = guard_.Drive(control.linear(), control.angular(), hold); !s.ok()) {
      Event(fmt::format("suggestion refused: {}", Text(s)));
      return absl::OkStatus();
    }
    // The hold starts with the drive, not at the scan: waiting for the answer (at rest) is no part
    // of it, or a slow server, or a simulator running faster than real time, would shorten it.
    double start = state->stamp;
    if (std::optional<adapters::BaseState> began = ReadBase(fatal)) start = began->stamp;
    if (!fatal.ok()) return fatal;
    double now = start;
    while (!stop.load() && guard_.moving() && now < start + hold - 1e-9) {
      SleepUnlessStopped(
          std::min(options_.odometry_period, start + hold - now) / options_.time_scale, stop);
      std::optional<adapters::BaseState> during = ReadBase(fatal);
      if (!fatal.ok()) return fatal;
      if (!during) continue;
      now = during->stamp;
      MaybeReportStatus();
      if (absl::Status s = SendOdometry(*during); !s.ok()) {
        StreamBroke(s);
        return absl::OkStatus();
      }
    }
    // A stream that ended mid-hold has stopped the motors from its callback, which ended the hold.
    if (stream_->ended()) {
      StreamBroke(absl::UnavailableError("the server ended the stream"));
      return absl::OkStatus();
    }
    return guard_.Stop();
  }

  // DONE or STUCK: the session suggests nothing but standing still from here on, so the robot
  // stops for good (it is at rest between holds already; the stop makes sure) and the run ends,
  // or with keep_running goes on standing.
  absl::Status EndExploration(const v1::ExplorationProgress& progress) {
    const absl::Status stopped = guard_.Stop();
    explored_ = true;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status_.exploration_end = progress;
      status_.behaviour = "finished";
    }
    Event(fmt::format(
        "exploration {}{}: robot stopped{}", client::ExplorationStateName(progress),
        progress.reason().empty() ? "" : ": " + progress.reason(),
        options_.keep_running ? "; it stands, streaming, until the run is stopped" : ""));
    return stopped;
  }

  client::SlamClient& client_;
  adapters::MobileBase& base_;
  adapters::LaserScanner& laser_;
  const RobotLoopOptions options_;
  SafetyGuard guard_;
  DeviceHealth base_health_;
  DeviceHealth laser_health_;
  EventCallback on_event_;
  StatusCallback on_status_;
  double next_status_ = 0;

  std::string session_id_;
  absl::Status session_gone_;
  bool explored_ = false;  // an answer said DONE or STUCK (active mode); loop thread only
  std::unique_ptr<client::SensorStream> stream_;  // reset by the loop thread only
  std::atomic<bool> closing_{false};              // the loop itself is ending the current stream
  std::atomic<bool> end_seen_{false};             // the current stream's break has stopped the base
  // The last stream ended because its session is moving between servers (fleet).
  bool handing_over_ = false;        // written by the loop under mutex_
  uint64_t reconnects_ = 0;         // written by the loop under mutex_ (Snapshot reads it)
  uint64_t scans_sent_before_ = 0;  // by streams already finished
  double last_odometry_stamp_ = -1e300;
  double last_scan_stamp_ = -1e300;

  mutable std::mutex mutex_;  // what the update callback and Snapshot() share
  RobotStatus status_;
  v1::SlamUpdate latest_;
  bool last_rejected_ = false;
  bool answered_since_open_ = false;
  client::AnsweredProgress answered_progress_;  // over every stream of the run
  std::vector<std::string> pending_warnings_;
  uint64_t suggestions_driven_ = 0;
  std::optional<double> start_stamp_;
  double last_base_stamp_ = 0;
};

RobotLoop::RobotLoop(client::SlamClient& client, adapters::MobileBase& base,
                     adapters::LaserScanner& laser, RobotLoopOptions options)
    : impl_(std::make_unique<Impl>(client, base, laser, std::move(options))) {}

RobotLoop::~RobotLoop() = default;

absl::StatusOr<RobotStatus> RobotLoop::Run(const std::atomic<bool>& stop) {
  return impl_->Run(stop, on_status_, on_event_);
}

absl::Status RobotLoop::Teleop(double linear, double angular) {
  return impl_->Teleop(linear, angular);
}

RobotStatus RobotLoop::status() const { return impl_->Snapshot(); }

}  // namespace waymark::cli
