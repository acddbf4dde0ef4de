#ifndef WAYMARK_CLIENT_DEVICES_PIONEER_BASE_H_
#define WAYMARK_CLIENT_DEVICES_PIONEER_BASE_H_

// The Pioneer 3-DX base over its ARCOS / P2OS serial link (issue 5), as a MobileBase.
//
// Connect() synchronises (SYNC0, SYNC1, SYNC2, each echoed; SYNC2's echo names the robot), closes
// and resynchronises a robot a previous program left open (it streams SIPs instead of echoing),
// then sends OPEN, PULSE, ENABLE 1 and SETO. A background thread then reads the port, decodes the
// standard SIPs (every 100 ms) into the latest BaseState and sends PULSE so the robot's ~2 s
// watchdog never stops it while this object lives. Commands from the caller's thread and PULSEs
// from the reader share one write mutex, so packets never interleave on the wire.
//
// Read() is UNAVAILABLE once the cable is unplugged or SIPs stop arriving: a robot loop must not
// act on stale odometry.

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/devices/p2os_packet.h"
#include "client/devices/p2os_sip.h"
#include "client/devices/robot_devices.h"
#include "client/devices/serial_port.h"

namespace waymark::adapters {

struct PioneerOptions {
  // ARCOS talks 9600 baud 8N1 on the robot's serial port out of the box.
  int baud = 9600;
  // Clamps for SetVelocity. A P3-DX can do about 1.2 m/s and 300 deg/s; these are conservative
  // indoor defaults for a robot running next to people.
  double max_linear = 0.5;   // m/s
  double max_angular = 1.0;  // rad/s
  // Distance between the drive wheels' contact points, to turn the SIP's wheel velocities into a
  // rotational velocity (the standard SIP has none). 2 / DiffConvFactor with the P3-DX's
  // DiffConvFactor 0.0056 (rad/s per mm/s of (R - L) / 2) from the ARIA parameter file p3dx.p.
  double wheel_base = 0.357;  // m
  // PULSE is sent when nothing else was written for this long; must stay well under the robot's
  // 2 s watchdog.
  absl::Duration pulse_interval = absl::Milliseconds(500);
  // How long to wait for each sync echo, and how often to try each sync step (and the CLOSE of a
  // robot left open) before giving up.
  absl::Duration sync_timeout = absl::Milliseconds(500);
  int sync_attempts = 3;
  // No SIP for this long (they come every 100 ms): Read() is UNAVAILABLE. Also how long Connect
  // waits for the first SIPs after OPEN.
  absl::Duration sip_timeout = absl::Seconds(1);
  // Send SETO at connect so odometry starts at (0, 0, 0). Without it the pose starts at the
  // robot's own counters (x and y modulo 32.768 m).
  bool reset_odometry = true;
};

class PioneerBase : public MobileBase {
 public:
  // Link health, for status lines.
  struct LinkStats {
    std::uint64_t sips = 0;           // standard SIPs decoded
    std::uint64_t bad_checksums = 0;  // packets dropped for a wrong checksum
    std::uint64_t bad_counts = 0;     // headers with an impossible byte count
    std::uint64_t skipped_bytes = 0;  // bytes outside any valid packet
    std::uint64_t bad_sips = 0;       // SIP ids whose payload did not decode
    double last_sip_age = -1;         // seconds since the last SIP; -1 before the first
    std::string robot_name;           // from the SYNC2 echo
    std::string robot_class;          // "Pioneer"
    std::string robot_subclass;       // "p3dx-sh", ...
    std::string error;                // why the link died; empty while it is up
  };

  // Opens `device`, synchronises and opens the robot. UNAVAILABLE with what to check when the
  // robot does not answer (naming the device and the step), INVALID_ARGUMENT for bad options,
  // NOT_FOUND / PERMISSION_DENIED from opening the port.
  static absl::StatusOr<std::unique_ptr<PioneerBase>> Connect(const std::string& device,
                                                              const PioneerOptions& options = {});
  // Stops the robot (VEL 0, RVEL 0), sends CLOSE and joins the reader thread. Best effort: the
  // cable may be gone.
  ~PioneerBase() override;
  PioneerBase(const PioneerBase&) = delete;
  PioneerBase& operator=(const PioneerBase&) = delete;

  // Clamps to [-max, max] and sends VEL (mm/s, rounded) and RVEL (deg/s, rounded: steps of
  // 0.017 rad/s). INVALID_ARGUMENT for NaN or infinite values (nothing is sent).
  absl::Status SetVelocity(double linear, double angular) override;
  // SetVelocity(0, 0); see the .cc for why not STOP.
  absl::Status Stop() override;
  // ESTOP: the robot stops at once, without its usual deceleration.
  absl::Status EmergencyStop();
  absl::StatusOr<BaseState> Read() override;
  double max_linear() const override { return options_.max_linear; }
  double max_angular() const override { return options_.max_angular; }

  LinkStats link() const;
  const std::string& device() const { return port_->path(); }

 private:
  PioneerBase(std::unique_ptr<SerialPort> port, const PioneerOptions& options);
  // Connect's steps, before the reader thread runs (they read the port themselves).
  absl::Status Synchronize();
  absl::Status OpenRobot();
  // Feeds the parser from the port for at most `timeout`; the first packet, if any.
  absl::StatusOr<std::optional<P2osPacket>> ReadPacket(absl::Duration timeout);
  void CopyParserCounters();  // into stats_; callers hold state_mutex_

  absl::Status Send(const std::vector<std::uint8_t>& packet);
  absl::Status SendInt(std::uint8_t id, int value);
  void ReaderLoop();
  void HandleSip(const P2osPacket& packet);

  const PioneerOptions options_;
  const std::unique_ptr<SerialPort> port_;
  P2osParser parser_;  // Connect's thread, then only the reader thread

  std::mutex write_mutex_;                        // one packet on the wire at a time
  absl::Time last_write_ = absl::InfinitePast();  // guarded by write_mutex_

  mutable std::mutex state_mutex_;
  SipOdometry odometry_;  // guarded by state_mutex_
  BaseState state_;       // guarded by state_mutex_
  absl::Time last_sip_ = absl::InfinitePast();
  LinkStats stats_;               // guarded by state_mutex_
  absl::Status link_error_;       // guarded by state_mutex_
  std::uint64_t bytes_read_ = 0;  // Connect's thread only: tells silence from a wrong baud

  bool opened_ = false;  // OPEN was sent: the destructor stops and closes the robot

  std::atomic<bool> stop_{false};
  std::thread reader_;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_PIONEER_BASE_H_
