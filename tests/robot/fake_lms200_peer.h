#ifndef WAYMARK_TESTS_ROBOT_FAKE_LMS200_PEER_H_
#define WAYMARK_TESTS_ROBOT_FAKE_LMS200_PEER_H_

// A SICK LMS200 on the master side of a pseudo-terminal, for testing the serial driver
// (client/devices/lms200_scanner.h) without the hardware.
//
// It behaves like the sensor as far as the driver can tell:
//   - it runs at one baud rate (9600 at power-up) and only understands the host while the host's
//     rate (PtyPair::host_baud(), the pair shares one termios) equals its own; bytes heard at
//     another rate are ignored (counted), and what it sends meanwhile is dropped, since a pty
//     cannot garble bytes the way a real rate mismatch does;
//   - telegrams 20 xx (operating mode, rates) are answered ACK + A0 (accepted byte, status);
//     3B (variant) ACK + BB (accepted byte, angle, resolution, status); anything else with NAK;
//   - after answering a rate command it switches its own rate;
//   - after 20 24 it streams B0 scans (mm units, ranges from a test function of the beam index)
//     every scan_period until 20 25.
// It logs every telegram it understood and every rate change of either side, and injects faults
// on request. All methods are thread-safe.

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "tests/robot/pty_pair.h"

namespace waymark::testing {

struct FakeLms200Options {
  int baud = 9600;         // rate at start (9600 after power-up)
  bool streaming = false;  // already streaming at start (left so by an earlier run)
  bool half_degree = false;
  absl::Duration scan_period = absl::Milliseconds(20);
  // Range of beam `beam` of `beam_count` in mm (13 bits: up to 8191). Default 1000 + beam.
  std::function<std::uint16_t(int beam, int beam_count)> range_mm;
};

// A range_mm for a robot standing in a 5 x 3 m room, 3 m from the wall ahead, 2 m from the one
// behind, 1.5 m from either side: walls for SLAM to map.
std::uint16_t RoomRangeMm(int beam, int beam_count);

// A telegram the fake understood.
struct FakeLms200Heard {
  std::vector<std::uint8_t> telegram;  // byte for byte, STX to CRC
  int baud = 0;                        // the rate both sides ran at
};

// A rate change seen by the fake, in the order it saw them.
struct FakeLms200RateEvent {
  bool laser = false;  // true: the fake's own rate; false: the host's
  int baud = 0;
};

class FakeLms200Peer {
 public:
  // Opens a pseudo-terminal and starts the peer on it.
  static absl::StatusOr<std::unique_ptr<FakeLms200Peer>> Start(FakeLms200Options options = {});
  ~FakeLms200Peer();
  FakeLms200Peer(const FakeLms200Peer&) = delete;
  FakeLms200Peer& operator=(const FakeLms200Peer&) = delete;

  // What the driver opens.
  const std::string& device_path() const { return device_path_; }

  std::vector<FakeLms200Heard> heard() const;
  // Command bytes (command + data) of each telegram heard, for compact checks.
  std::vector<std::vector<std::uint8_t>> commands() const;
  std::vector<FakeLms200RateEvent> rate_events() const;
  int baud() const;
  bool streaming() const;
  int beam_count() const;
  std::uint64_t scans_sent() const;     // scans that went out whole
  std::uint64_t ignored_bytes() const;  // heard while the rates differed

  // Faults, sent between telegrams in the order asked for.
  void SendGarbage(std::vector<std::uint8_t> bytes);
  void SendBadCrcScan();  // a scan whose CRC is off by one
  void SendNak();
  void SendScanOfSize(int beam_count);  // a valid scan with another beam count
  // Answers the next `count` commands with a NAK instead of ACK + reply.
  void NakNextCommands(int count);
  // Stops all output, as a sensor that died would (it still listens and logs).
  void Mute();
  // Closes the master side: the driver sees the cable unplugged. Stops the peer.
  void Hangup();

 private:
  FakeLms200Peer(PtyPair pty, FakeLms200Options options);
  void Run();
  void PollHostRate();
  void Handle(const std::vector<std::uint8_t>& command_and_data);
  std::vector<std::uint8_t> Scan(int beam_count) const;
  // Sends unless the rates differ; gives up on a full line rather than block the peer. True when
  // all bytes went out.
  bool Send(const std::vector<std::uint8_t>& bytes);

  PtyPair pty_;
  const std::string device_path_;
  const FakeLms200Options options_;

  mutable std::mutex mutex_;
  int baud_;
  int last_host_baud_ = -1;
  bool streaming_;
  int angle_ = 180;
  int resolution_;  // 1/100 degree
  int naks_to_send_ = 0;
  bool muted_ = false;
  std::uint64_t scans_sent_ = 0;
  std::uint64_t ignored_bytes_ = 0;
  std::vector<FakeLms200Heard> heard_;
  std::vector<FakeLms200RateEvent> rate_events_;
  std::deque<std::vector<std::uint8_t>> faults_;

  std::atomic<bool> stop_{false};
  bool hangup_ = false;
  std::thread thread_;
};

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_ROBOT_FAKE_LMS200_PEER_H_
