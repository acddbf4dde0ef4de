#include "client/devices/pioneer_base.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::adapters {
namespace {

constexpr std::uint8_t kSipStopped = 0x32;
constexpr std::uint8_t kSipMoving = 0x33;
constexpr const char* kSyncNames[] = {"SYNC0", "SYNC1", "SYNC2"};
// The reader's poll period: how late a PULSE or the destructor's stop can be.
constexpr absl::Duration kReadSlice = absl::Milliseconds(20);
// After CLOSE to a robot left open, its SIPs stop; we wait this long without a packet before
// resynchronising (SIPs come every 100 ms).
constexpr absl::Duration kQuietAfterClose = absl::Milliseconds(300);

bool IsSip(const P2osPacket& packet) { return packet.id == kSipStopped || packet.id == kSipMoving; }

double HostSeconds() { return absl::ToDoubleSeconds(absl::Now() - absl::UnixEpoch()); }

absl::Status ValidateOptions(const PioneerOptions& o) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!IsSupportedBaud(o.baud)) {
    return absl::InvalidArgumentError(absl::StrCat("unsupported baud rate ", o.baud,
                                                   " (ARCOS uses 9600, 19200, 38400 or 115200)"));
  }
  if (!positive(o.max_linear) || !positive(o.max_angular)) {
    return absl::InvalidArgumentError("max_linear and max_angular must be positive");
  }
  if (!positive(o.wheel_base)) return absl::InvalidArgumentError("wheel_base must be positive");
  // The robot's watchdog stops it after about 2 s without a packet.
  if (o.pulse_interval <= absl::ZeroDuration() || o.pulse_interval >= absl::Milliseconds(1500)) {
    return absl::InvalidArgumentError(
        absl::StrCat("pulse_interval ", absl::FormatDuration(o.pulse_interval),
                     " must be in (0, 1.5 s): the robot's watchdog stops it after ~2 s"));
  }
  if (o.sync_timeout <= absl::ZeroDuration() || o.sync_attempts < 1 ||
      o.sip_timeout <= absl::ZeroDuration()) {
    return absl::InvalidArgumentError(
        "sync_timeout and sip_timeout must be positive, sync_attempts at least 1");
  }
  return absl::OkStatus();
}

}  // namespace

PioneerBase::PioneerBase(std::unique_ptr<SerialPort> port, const PioneerOptions& options)
    : options_(options), port_(std::move(port)) {}

absl::StatusOr<std::unique_ptr<PioneerBase>> PioneerBase::Connect(const std::string& device,
                                                                  const PioneerOptions& options) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  absl::StatusOr<std::unique_ptr<SerialPort>> port = SerialPort::Open(device, options.baud);
  if (!port.ok()) return port.status();
  std::unique_ptr<PioneerBase> base(new PioneerBase(std::move(*port), options));
  if (absl::Status s = base->Synchronize(); !s.ok()) return s;
  if (absl::Status s = base->OpenRobot(); !s.ok()) return s;
  base->reader_ = std::thread([b = base.get()] { b->ReaderLoop(); });
  return base;
}

PioneerBase::~PioneerBase() {
  stop_ = true;
  if (reader_.joinable()) reader_.join();
  // After the join, so no PULSE follows CLOSE (a closed robot would take it for SYNC0).
  if (opened_) {
    SendInt(p2os::kVel, 0).IgnoreError();
    SendInt(p2os::kRotVel, 0).IgnoreError();
    Send(EncodeP2osCommand(p2os::kClose)).IgnoreError();
  }
}

absl::Status PioneerBase::Send(const std::vector<std::uint8_t>& packet) {
  std::lock_guard<std::mutex> lock(write_mutex_);
  absl::Status status = port_->Write(packet);
  if (status.ok()) last_write_ = absl::Now();
  return status;
}

absl::Status PioneerBase::SendInt(std::uint8_t id, int value) {
  absl::StatusOr<std::vector<std::uint8_t>> packet = EncodeP2osCommand(id, value);
  if (!packet.ok()) return packet.status();
  return Send(*packet);
}

void PioneerBase::CopyParserCounters() {
  stats_.bad_checksums = parser_.bad_checksums();
  stats_.bad_counts = parser_.bad_counts();
  stats_.skipped_bytes = parser_.skipped_bytes();
}

absl::StatusOr<std::optional<P2osPacket>> PioneerBase::ReadPacket(absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  std::uint8_t buffer[256];
  while (true) {
    if (std::optional<P2osPacket> packet = parser_.Next()) return packet;
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) return std::nullopt;
    absl::StatusOr<std::size_t> n = port_->Read(buffer, sizeof(buffer), left);
    if (!n.ok()) return n.status();
    bytes_read_ += *n;
    parser_.Feed(buffer, *n);
  }
}

absl::Status PioneerBase::Synchronize() {
  const std::string& path = port_->path();
  int step = 0;
  int tries = 0;
  int closes = 0;
  while (step < 3) {
    if (tries >= options_.sync_attempts) {
      if (step == 0 && bytes_read_ > 0) {
        return absl::UnavailableError(absl::StrCat(
            "received ", bytes_read_, " bytes from ", path, " but no answer to SYNC0 after ", tries,
            " attempts: wrong baud rate (", options_.baud,
            " now; ARCOS uses 9600 unless reconfigured) or another device on this port?"));
      }
      if (step == 0) {
        return absl::UnavailableError(
            absl::StrCat("no answer to SYNC0 from ", path, " after ", tries,
                         " attempts: is the robot on and the cable in the right port?"));
      }
      return absl::UnavailableError(absl::StrCat(
          "the robot on ", path, " answered ", kSyncNames[step - 1], " but not ", kSyncNames[step],
          " after ", tries, " attempts: power-cycle the robot and retry"));
    }
    if (absl::Status s = Send(EncodeP2osCommand(static_cast<std::uint8_t>(step))); !s.ok()) {
      return s;
    }
    ++tries;
    const absl::Time deadline = absl::Now() + options_.sync_timeout;
    bool left_open = false;
    while (true) {
      absl::StatusOr<std::optional<P2osPacket>> packet = ReadPacket(deadline - absl::Now());
      if (!packet.ok()) return packet.status();
      if (!packet->has_value()) break;  // timed out: send the step again
      const P2osPacket& p = **packet;
      if (p.id == step) {
        if (step == 2) {
          // SYNC2's echo: name, class and subclass, each NUL-terminated.
          std::string* fields[] = {&stats_.robot_name, &stats_.robot_class, &stats_.robot_subclass};
          std::size_t at = 0;
          for (std::string* field : fields) {
            if (at >= p.payload.size()) break;
            auto end = std::find(p.payload.begin() + at, p.payload.end(), 0);
            field->assign(p.payload.begin() + at, end);
            at = static_cast<std::size_t>(end - p.payload.begin()) + 1;
          }
        }
        ++step;
        tries = 0;
        break;
      }
      // A late echo of an earlier step is harmless; anything else means the robot is open and
      // streaming (it takes SYNC0 for PULSE and SYNC1 for OPEN).
      if (p.id > 2) {
        left_open = true;
        break;
      }
    }
    if (!left_open) continue;
    if (closes >= options_.sync_attempts) {
      return absl::UnavailableError(
          absl::StrCat("the robot on ", path, " keeps streaming SIPs after ", closes,
                       " CLOSE commands: power-cycle the robot and retry"));
    }
    if (absl::Status s = Send(EncodeP2osCommand(p2os::kClose)); !s.ok()) return s;
    ++closes;
    // Let the SIPs already on their way arrive, then start over from SYNC0.
    const absl::Time give_up = absl::Now() + 2 * options_.sync_timeout + kQuietAfterClose;
    while (absl::Now() < give_up) {
      absl::StatusOr<std::optional<P2osPacket>> packet = ReadPacket(kQuietAfterClose);
      if (!packet.ok()) return packet.status();
      if (!packet->has_value()) break;
    }
    port_->DiscardInput();
    step = 0;
    tries = 0;
  }
  std::lock_guard<std::mutex> lock(state_mutex_);
  CopyParserCounters();
  return absl::OkStatus();
}

absl::Status PioneerBase::OpenRobot() {
  opened_ = true;
  if (absl::Status s = Send(EncodeP2osCommand(p2os::kOpen)); !s.ok()) return s;
  if (absl::Status s = Send(EncodeP2osCommand(p2os::kPulse)); !s.ok()) return s;
  if (absl::Status s = SendInt(p2os::kEnable, 1); !s.ok()) return s;
  if (options_.reset_odometry) {
    if (absl::Status s = Send(EncodeP2osCommand(p2os::kSetOdometry)); !s.ok()) return s;
  }
  // The first SIP may have been built before SETO took effect: with a reset, odometry starts at
  // the second one, so it never jumps from the old counters to zero.
  const int wanted = options_.reset_odometry ? 2 : 1;
  int seen = 0;
  const absl::Time deadline = absl::Now() + options_.sip_timeout + absl::Milliseconds(200);
  while (seen < wanted) {
    absl::StatusOr<std::optional<P2osPacket>> packet = ReadPacket(deadline - absl::Now());
    if (!packet.ok()) return packet.status();
    if (!packet->has_value()) {
      return absl::UnavailableError(
          absl::StrCat("the robot on ", port_->path(), " synchronised but sent no SIP within ",
                       absl::FormatDuration(options_.sip_timeout), " of OPEN"));
    }
    if (!IsSip(**packet)) continue;
    if (++seen == wanted) HandleSip(**packet);
  }
  return absl::OkStatus();
}

void PioneerBase::HandleSip(const P2osPacket& packet) {
  absl::StatusOr<StandardSip> sip = DecodeStandardSip(packet);
  std::lock_guard<std::mutex> lock(state_mutex_);
  if (!sip.ok()) {
    ++stats_.bad_sips;
    return;
  }
  const SipOdometry::Pose pose = odometry_.Update(*sip);
  state_.stamp = HostSeconds();
  state_.odometry = BasePose{pose.x, pose.y, pose.theta};
  state_.linear = (sip->left_velocity + sip->right_velocity) / 2.0 / 1000.0;
  state_.angular = (sip->right_velocity - sip->left_velocity) / 1000.0 / options_.wheel_base;
  state_.bumped = sip->front_bumpers != 0 || sip->rear_bumpers != 0;
  state_.stalled = sip->left_stall || sip->right_stall;
  state_.motors_enabled = sip->motors_enabled;
  state_.battery_volts = sip->battery_volts;
  last_sip_ = absl::Now();
  ++stats_.sips;
}

void PioneerBase::ReaderLoop() {
  std::uint8_t buffer[512];
  while (!stop_) {
    absl::StatusOr<std::size_t> n = port_->Read(buffer, sizeof(buffer), kReadSlice);
    if (!n.ok()) {
      std::lock_guard<std::mutex> lock(state_mutex_);
      link_error_ = n.status();
      stats_.error = std::string(n.status().message());
      return;  // the device is gone; it does not come back under the same descriptor
    }
    parser_.Feed(buffer, *n);
    while (std::optional<P2osPacket> packet = parser_.Next()) {
      if (IsSip(*packet)) HandleSip(*packet);  // other packets (config, encoders) unused
    }
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      CopyParserCounters();
    }
    // PULSE only when the line was quiet: any packet resets the robot's watchdog, and at 9600
    // baud the line is better left to velocity commands.
    bool due;
    {
      std::lock_guard<std::mutex> lock(write_mutex_);
      due = absl::Now() - last_write_ >= options_.pulse_interval;
    }
    if (due) {
      if (absl::Status s = Send(EncodeP2osCommand(p2os::kPulse)); !s.ok()) {
        std::lock_guard<std::mutex> lock(state_mutex_);
        link_error_ = s;
        stats_.error = std::string(s.message());
        return;
      }
    }
  }
}

absl::Status PioneerBase::SetVelocity(double linear, double angular) {
  if (!std::isfinite(linear) || !std::isfinite(angular)) {
    return absl::InvalidArgumentError(
        absl::StrCat("velocity (", linear, " m/s, ", angular, " rad/s) is not finite"));
  }
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    if (!link_error_.ok()) {
      return absl::UnavailableError(
          absl::StrCat("Pioneer link on ", port_->path(), " is down: ", link_error_.message()));
    }
  }
  linear = std::clamp(linear, -options_.max_linear, options_.max_linear);
  angular = std::clamp(angular, -options_.max_angular, options_.max_angular);
  const int mm_per_s = static_cast<int>(std::lround(linear * 1000.0));
  const int deg_per_s = static_cast<int>(std::lround(angular * 180.0 / M_PI));
  if (absl::Status s = SendInt(p2os::kVel, mm_per_s); !s.ok()) return s;
  return SendInt(p2os::kRotVel, deg_per_s);
}

// VEL 0 + RVEL 0 rather than STOP: Stop() is then exactly SetVelocity(0, 0), the same two
// commands as any velocity change (the robot decelerates at its configured rates), so there is one
// command path to test and nothing depends on how a given ARCOS / P2OS version treats STOP. The
// abrupt stop is EmergencyStop() (ESTOP).
absl::Status PioneerBase::Stop() { return SetVelocity(0, 0); }

absl::Status PioneerBase::EmergencyStop() { return Send(EncodeP2osCommand(p2os::kEmergencyStop)); }

absl::StatusOr<BaseState> PioneerBase::Read() {
  std::lock_guard<std::mutex> lock(state_mutex_);
  if (!link_error_.ok()) {
    return absl::UnavailableError(
        absl::StrCat("Pioneer link on ", port_->path(), " is down: ", link_error_.message()));
  }
  const absl::Duration age = absl::Now() - last_sip_;
  if (age > options_.sip_timeout) {
    return absl::UnavailableError(absl::StrFormat(
        "no SIP from the robot on %s for %.1f s (switched off, cable out, or its serial link "
        "hung)",
        port_->path(), absl::ToDoubleSeconds(age)));
  }
  return state_;
}

PioneerBase::LinkStats PioneerBase::link() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  LinkStats stats = stats_;
  stats.last_sip_age =
      last_sip_ == absl::InfinitePast() ? -1 : absl::ToDoubleSeconds(absl::Now() - last_sip_);
  return stats;
}

}  // namespace waymark::adapters
