#include "tests/robot/fake_arcos_peer.h"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <utility>

#include "client/devices/p2os_packet.h"
#include "client/devices/p2os_sip.h"

namespace waymark::testing {
namespace {

namespace p2os = adapters::p2os;

constexpr double kThetaUnit = 2.0 * M_PI / 4096.0;
constexpr absl::Duration kReadSlice = absl::Milliseconds(5);
// VEL2 wheel velocities come in these steps (ARIA's Vel2Divisor for the P3-DX).
constexpr int kVel2UnitMmPerS = 20;

std::vector<std::uint8_t> Packet(std::uint8_t id, const std::vector<std::uint8_t>& args = {}) {
  return *adapters::EncodeP2osPacket(id, args);
}

}  // namespace

FakeArcosPeer::FakeArcosPeer(PtyPair pty, const FakeArcosOptions& options)
    : pty_(std::move(pty)), options_(options), device_path_(pty_.device_path()) {
  last_packet_ = absl::Now();
  if (options_.left_open) {
    // A previous client crashed: open, motors on, somewhere away from the origin.
    open_ = true;
    motors_enabled_ = true;
    x_mm_ = 1234;
    y_mm_ = -567;
    theta_ = 0.5;
  }
  thread_ = std::thread([this] { Run(); });
}

FakeArcosPeer::~FakeArcosPeer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  if (thread_.joinable()) thread_.join();
}

void FakeArcosPeer::Send(const std::vector<std::uint8_t>& bytes) {
  const int fd = pty_.master_fd();
  std::size_t done = 0;
  while (fd >= 0 && done < bytes.size()) {
    // Bounded wait: a driver that stopped reading must not wedge the peer's thread.
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, 100) <= 0) return;
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      return;
    }
    done += static_cast<std::size_t>(n);
  }
}

void FakeArcosPeer::Run() {
  adapters::P2osParser parser;
  absl::Time next_sip = absl::Now() + options_.sip_period;
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) return;
      if (hangup_requested_) {
        pty_.Hangup();
        return;
      }
    }
    const std::vector<std::uint8_t> bytes = pty_.ReadSome(kReadSlice);
    if (!bytes.empty()) {
      std::lock_guard<std::mutex> lock(mutex_);
      received_.insert(received_.end(), bytes.begin(), bytes.end());
      parser.Feed(bytes.data(), bytes.size());
      while (std::optional<adapters::P2osPacket> packet = parser.Next()) {
        std::vector<std::uint8_t> body = {packet->id};
        body.insert(body.end(), packet->payload.begin(), packet->payload.end());
        Handle(body);
      }
      changed_.notify_all();
    }
    std::deque<std::vector<std::uint8_t>> out;
    std::vector<std::uint8_t> sip;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      out.swap(outbox_);
      const absl::Time now = absl::Now();
      if (open_ && !watchdog_tripped_ && now - last_packet_ > options_.watchdog) {
        vel_ = 0;
        rvel_ = 0;
        vel2_mode_ = false;
        watchdog_tripped_ = true;
        ++watchdog_trips_;
        changed_.notify_all();
      }
      if (now >= next_sip) {
        next_sip += options_.sip_period;
        if (next_sip < now) next_sip = now + options_.sip_period;  // fell behind: no burst
        if (open_) {
          // The robot's model advances one nominal period per SIP, so the pose it reports is
          // exactly what it integrated, whatever the host's scheduling.
          Integrate(absl::ToDoubleSeconds(options_.sip_period));
          if (!sips_paused_) {
            sip = SipPacket();
            ++sips_sent_;
          }
        }
      }
    }
    if (options_.silent) continue;
    for (const auto& bytes_out : out) Send(bytes_out);
    if (!sip.empty()) Send(sip);
  }
}

void FakeArcosPeer::Handle(const std::vector<std::uint8_t>& body) {
  Command command;
  command.id = body[0];
  if (body.size() >= 4 && (body[1] == p2os::kPositiveInt || body[1] == p2os::kNegativeInt)) {
    command.has_arg = true;
    const int magnitude = body[2] | (body[3] << 8);
    command.arg = body[1] == p2os::kNegativeInt ? -magnitude : magnitude;
  }
  last_packet_ = absl::Now();
  watchdog_tripped_ = false;
  const std::uint8_t id = command.id;
  if (!open_) {
    // Closed: the sync handshake, then OPEN. Out of order, the robot starts over.
    if (id == p2os::kSync0) {
      command.name = "SYNC0";
      outbox_.push_back(Packet(p2os::kSync0));
      sync_step_ = 1;
    } else if (id == p2os::kSync1 && sync_step_ == 1) {
      command.name = "SYNC1";
      outbox_.push_back(Packet(p2os::kSync1));
      sync_step_ = 2;
    } else if (id == p2os::kSync2 && sync_step_ == 2) {
      command.name = "SYNC2";
      std::vector<std::uint8_t> names;
      for (const std::string* s : {&options_.name, &options_.robot_class, &options_.subclass}) {
        names.insert(names.end(), s->begin(), s->end());
        names.push_back(0);
      }
      outbox_.push_back(Packet(p2os::kSync2, names));
      sync_step_ = 3;
    } else if (id == p2os::kOpen && sync_step_ == 3) {
      command.name = "OPEN";
      open_ = true;
      vel_ = 0;
      rvel_ = 0;
      vel2_mode_ = false;
      // The first SIP goes out at once, built before the commands that follow OPEN in the same
      // burst (SETO, say) are seen: the driver must not take its pose for the reset one.
      outbox_.push_back(SipPacket());
      ++sips_sent_;
    } else {
      command.name = "?";
      sync_step_ = 0;
    }
    if (options_.silent) outbox_.clear();
    commands_.push_back(command);
    return;
  }
  switch (id) {
    case p2os::kPulse:
      command.name = "PULSE";
      break;
    case p2os::kOpen:
      command.name = "OPEN";
      break;
    case p2os::kClose:
      command.name = "CLOSE";
      open_ = false;
      sync_step_ = 0;
      vel_ = 0;
      rvel_ = 0;
      vel2_mode_ = false;
      break;
    case p2os::kEnable:
      command.name = "ENABLE";
      motors_enabled_ = command.has_arg && command.arg != 0;
      break;
    case p2os::kSetOdometry:
      command.name = "SETO";
      x_mm_ = y_mm_ = theta_ = 0;
      break;
    case p2os::kVel:
      command.name = "VEL";
      vel_ = command.arg;
      if (vel2_mode_) rvel_ = 0;
      vel2_mode_ = false;
      break;
    case p2os::kRotVel:
      command.name = "RVEL";
      rvel_ = command.arg;
      if (vel2_mode_) vel_ = 0;
      vel2_mode_ = false;
      break;
    case p2os::kVel2: {
      // Left wheel in the high byte, right in the low byte, each a signed count of 20 mm/s.
      command.name = "VEL2";
      const auto word = static_cast<std::uint16_t>(command.arg);
      vel2_left_ = static_cast<std::int8_t>(word >> 8) * kVel2UnitMmPerS;
      vel2_right_ = static_cast<std::int8_t>(word & 0xFF) * kVel2UnitMmPerS;
      vel2_mode_ = true;
      break;
    }
    case p2os::kStop:
    case p2os::kEmergencyStop:
      command.name = id == p2os::kStop ? "STOP" : "ESTOP";
      vel_ = 0;
      rvel_ = 0;
      vel2_mode_ = false;
      break;
    default:
      command.name = "?";
  }
  commands_.push_back(command);
}

void FakeArcosPeer::Integrate(double seconds) {
  if (!motors_enabled_) return;
  double v, w;  // mm/s, rad/s
  if (vel2_mode_) {
    v = (vel2_left_ + vel2_right_) / 2.0;
    w = (vel2_right_ - vel2_left_) / options_.wheel_base_mm;
  } else {
    v = vel_;
    w = rvel_ * M_PI / 180.0;
  }
  const double mid = theta_ + w * seconds / 2;
  x_mm_ += v * std::cos(mid) * seconds;
  y_mm_ += v * std::sin(mid) * seconds;
  theta_ = std::remainder(theta_ + w * seconds, 2 * M_PI);
}

std::vector<std::uint8_t> FakeArcosPeer::SipPacket() {
  double left = 0, right = 0;  // mm/s
  if (motors_enabled_) {
    if (vel2_mode_) {
      left = vel2_left_;
      right = vel2_right_;
    } else {
      const double half_spread = rvel_ * M_PI / 180.0 * options_.wheel_base_mm / 2;
      left = vel_ - half_spread;
      right = vel_ + half_spread;
    }
  }
  adapters::StandardSip sip;
  sip.moving = left != 0 || right != 0;
  sip.x_raw = static_cast<int>(std::lround(x_mm_));
  sip.y_raw = static_cast<int>(std::lround(y_mm_));
  sip.theta_raw = static_cast<int>(std::lround(theta_ / kThetaUnit));
  sip.left_velocity = static_cast<int>(std::lround(left));
  sip.right_velocity = static_cast<int>(std::lround(right));
  sip.battery_volts = options_.battery_volts;
  sip.left_stall = left_stall_;
  sip.right_stall = right_stall_;
  sip.front_bumpers = front_bumpers_;
  sip.rear_bumpers = rear_bumpers_;
  sip.motors_enabled = motors_enabled_;
  return Packet(sip.moving ? 0x33 : 0x32, adapters::EncodeStandardSipPayload(sip));
}

std::vector<std::uint8_t> FakeArcosPeer::received_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return received_;
}

std::vector<FakeArcosPeer::Command> FakeArcosPeer::commands() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return commands_;
}

int FakeArcosPeer::Count(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(std::count_if(commands_.begin(), commands_.end(),
                                        [&](const Command& c) { return c.name == name; }));
}

std::pair<int, int> FakeArcosPeer::last_velocities() const {
  std::lock_guard<std::mutex> lock(mutex_);
  int vel = 0, rvel = 0;
  for (const Command& c : commands_) {
    if (c.name == "VEL") vel = c.arg;
    if (c.name == "RVEL") rvel = c.arg;
  }
  return {vel, rvel};
}

bool FakeArcosPeer::ever_moved() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::any_of(commands_.begin(), commands_.end(), [](const Command& c) {
    return (c.name == "VEL" || c.name == "RVEL") && c.arg != 0;
  });
}

bool FakeArcosPeer::is_open() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return open_;
}

bool FakeArcosPeer::motors_enabled() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return motors_enabled_;
}

FakeArcosPeer::Pose FakeArcosPeer::pose() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return Pose{x_mm_ / 1000.0, y_mm_ / 1000.0, theta_};
}

int FakeArcosPeer::watchdog_trips() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return watchdog_trips_;
}

std::uint64_t FakeArcosPeer::sips_sent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sips_sent_;
}

bool FakeArcosPeer::WaitFor(const std::function<bool(const std::vector<Command>&)>& predicate,
                            absl::Duration timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                           [&] { return predicate(commands_); });
}

void FakeArcosPeer::SetBumpers(std::uint8_t front, std::uint8_t rear) {
  std::lock_guard<std::mutex> lock(mutex_);
  front_bumpers_ = front;
  rear_bumpers_ = rear;
}

void FakeArcosPeer::SetStall(bool left, bool right) {
  std::lock_guard<std::mutex> lock(mutex_);
  left_stall_ = left;
  right_stall_ = right;
}

void FakeArcosPeer::PauseSips(bool paused) {
  std::lock_guard<std::mutex> lock(mutex_);
  sips_paused_ = paused;
}

void FakeArcosPeer::InjectBytes(const std::vector<std::uint8_t>& bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  outbox_.push_back(bytes);
}

void FakeArcosPeer::InjectCorruptSip() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::uint8_t> packet = SipPacket();
  packet.back() ^= 0x01;
  outbox_.push_back(std::move(packet));
}

void FakeArcosPeer::Hangup() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    hangup_requested_ = true;
  }
  if (thread_.joinable()) thread_.join();
}

}  // namespace waymark::testing
