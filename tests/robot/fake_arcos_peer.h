#ifndef WAYMARK_TESTS_ROBOT_FAKE_ARCOS_PEER_H_
#define WAYMARK_TESTS_ROBOT_FAKE_ARCOS_PEER_H_

// A fake Pioneer ARCOS controller on the master side of a pseudo-terminal, for testing the base
// driver (client/devices/pioneer_base.h) without a robot.
//
// Closed, it answers SYNC0, SYNC1 and SYNC2 in order (SYNC2 with name, class and subclass); after
// OPEN it streams standard SIPs every `sip_period`, integrating the commanded VEL / RVEL (or VEL2)
// into its pose so odometry follows the commands. Open, ids 0, 1 and 2 mean PULSE, OPEN and CLOSE,
// as on the robot, so a peer "left open" ignores syncs until it gets CLOSE. Its watchdog zeroes
// the velocities after `watchdog` without any packet. Tests inject bumper and stall bits, garbage
// bytes and corrupted packets, and unplug the cable.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/time/time.h"
#include "tests/robot/pty_pair.h"

namespace waymark::testing {

struct FakeArcosOptions {
  std::string name = "waymark-fake";
  std::string robot_class = "Pioneer";
  std::string subclass = "p3dx-sh";
  bool left_open = false;  // starts open and streaming, as after a crashed client
  bool silent = false;     // never sends anything (robot off, wrong port)
  absl::Duration sip_period = absl::Milliseconds(100);
  absl::Duration watchdog = absl::Seconds(2);
  double wheel_base_mm = 357;  // to split (v, w) into wheel velocities; PioneerOptions' default
  double battery_volts = 12.6;
};

class FakeArcosPeer {
 public:
  // One packet received, as the peer understood it.
  struct Command {
    std::uint8_t id = 0;
    std::string name;  // "SYNC0", "PULSE", "VEL", ... ("?" for ids it ignores)
    bool has_arg = false;
    int arg = 0;
  };
  struct Pose {
    double x = 0, y = 0, theta = 0;  // m, m, rad
  };

  FakeArcosPeer(PtyPair pty, const FakeArcosOptions& options = {});
  ~FakeArcosPeer();
  FakeArcosPeer(const FakeArcosPeer&) = delete;
  FakeArcosPeer& operator=(const FakeArcosPeer&) = delete;

  const std::string& device_path() const { return device_path_; }

  // Everything the driver wrote, byte for byte, and the packets decoded from it.
  std::vector<std::uint8_t> received_bytes() const;
  std::vector<Command> commands() const;
  int Count(const std::string& name) const;
  // The arguments of the last VEL and RVEL received (0 before any): (0, 0) = told to stand.
  std::pair<int, int> last_velocities() const;
  // Whether any VEL or RVEL ever asked for motion.
  bool ever_moved() const;
  bool is_open() const;
  bool motors_enabled() const;
  Pose pose() const;
  int watchdog_trips() const;
  std::uint64_t sips_sent() const;

  // Waits until `predicate` (called under the peer's lock with the command log) holds or
  // `timeout` passes; returns whether it held.
  bool WaitFor(const std::function<bool(const std::vector<Command>&)>& predicate,
               absl::Duration timeout) const;

  void SetBumpers(std::uint8_t front, std::uint8_t rear);
  void SetStall(bool left, bool right);
  void PauseSips(bool paused);  // SIPs stop while the peer stays open, as with a hung controller
  // Sent by the peer's thread between packets.
  void InjectBytes(const std::vector<std::uint8_t>& bytes);
  void InjectCorruptSip();  // a SIP whose checksum is off by one
  // Closes the master: the driver sees the cable unplugged. The peer stops.
  void Hangup();

 private:
  void Run();
  void Handle(const std::vector<std::uint8_t>& body);  // id .. args, checksum stripped
  void Integrate(double seconds);                      // caller holds mutex_
  std::vector<std::uint8_t> SipPacket();               // caller holds mutex_
  void Send(const std::vector<std::uint8_t>& bytes);   // peer thread only

  PtyPair pty_;
  const FakeArcosOptions options_;
  const std::string device_path_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::vector<std::uint8_t> received_;
  std::vector<Command> commands_;
  int sync_step_ = 0;  // closed: the next sync expected
  bool open_ = false;
  bool motors_enabled_ = false;
  bool sips_paused_ = false;
  double x_mm_ = 0, y_mm_ = 0, theta_ = 0;
  int vel_ = 0;        // mm/s
  double rvel_ = 0;    // deg/s
  int vel2_left_ = 0;  // mm/s; VEL2 overrides VEL / RVEL until the next VEL or RVEL
  int vel2_right_ = 0;
  bool vel2_mode_ = false;
  std::uint8_t front_bumpers_ = 0, rear_bumpers_ = 0;
  bool left_stall_ = false, right_stall_ = false;
  int watchdog_trips_ = 0;
  bool watchdog_tripped_ = false;
  absl::Time last_packet_;
  std::uint64_t sips_sent_ = 0;
  std::deque<std::vector<std::uint8_t>> outbox_;  // injected and reply bytes
  bool hangup_requested_ = false;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_ROBOT_FAKE_ARCOS_PEER_H_
