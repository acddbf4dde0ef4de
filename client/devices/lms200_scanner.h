#ifndef WAYMARK_CLIENT_DEVICES_LMS200_SCANNER_H_
#define WAYMARK_CLIENT_DEVICES_LMS200_SCANNER_H_

// The SICK LMS200 on a serial port (issue 5) as a LaserScanner: 180 degrees at 1 degree (181
// beams) or 0.5 degree (361 beams), streamed continuously at the chosen baud rate.
//
// Connect() brings the sensor from whatever state it is in to streaming:
//   1. find its rate: the LMS200 powers up at 9600 baud but keeps a rate set by an earlier run
//      until it is power-cycled, so the host sends "stop continuous output" (20 25) at 9600, then
//      at the other rates, until an answer comes back;
//   2. set the variant (3B B4 00 64|32 00) and check the echoed angle and resolution;
//   3. switch the laser's rate (20 40/41/42/48, sent and answered at the old rate), then the
//      host's: the other order would leave the two talking past each other;
//   4. request continuous output (20 24).
// Read() then returns the scans (B0 telegrams) in order of arrival, stamped with the host clock.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/devices/lms200_telegram.h"
#include "client/devices/robot_devices.h"
#include "client/devices/serial_port.h"

namespace waymark::adapters {

struct Lms200Options {
  // Rate to stream at: 9600, 19200, 38400 (RS-232 tops out here) or 500000 (RS-422 only). A 181
  // beam scan is 372 bytes, so 38400 baud carries about 10 scans/s and 9600 fewer than 3.
  int baud = 38400;
  // false: 181 beams at 1 degree; true: 361 beams at 0.5 degree (the sensor interlaces two
  // sweeps, so a full scan takes twice as long).
  bool half_degree = false;
  // Laser pose on the robot, as the simulator's SimOptions::laser_mount (P3-DX front mount).
  BasePose mount{0.16, 0.0, 0.0};
  // How long to wait for the answer to one command, and how often to send it.
  absl::Duration reply_timeout = absl::Milliseconds(500);
  int retries = 3;
  // The sensor needs a moment after changing its rate before it listens at the new one (the
  // sicktoolbox driver waits 250 ms after its SetSessionBaud).
  absl::Duration baud_switch_pause = absl::Milliseconds(250);
  // Read() fails UNAVAILABLE when no scan arrived for this long.
  absl::Duration scan_timeout = absl::Seconds(1);
  // Readings at or above are no-returns. In the factory mm mode (8 m range) the 13-bit values
  // from 8183 mm up are not distances but the sensor's codes for no echo, dazzle and measuring
  // errors, as the telegram notes say. A sensor configured for cm mode reports up to
  // 81.82 m: set 81.83 then.
  double no_return_range = 8.183;
};

// Counters for status lines; everything since Connect() started.
struct Lms200Stats {
  std::uint64_t scans = 0;             // scans returned by Read()
  std::uint64_t wrong_size_scans = 0;  // B0 telegrams whose beam count is not the layout's
  std::uint64_t other_telegrams = 0;   // valid telegrams that are neither a scan nor awaited
  std::uint64_t bad_crcs = 0;
  std::uint64_t naks = 0;
  std::uint64_t skipped_bytes = 0;  // bytes outside any valid telegram
};

class Lms200Scanner : public LaserScanner {
 public:
  // Errors: INVALID_ARGUMENT for bad options; the port's errors (NOT_FOUND, PERMISSION_DENIED,
  // ...); UNAVAILABLE when the sensor answers at no rate; DEADLINE_EXCEEDED when it stops
  // answering after it was found; FAILED_PRECONDITION when it refuses a command. All name the
  // device.
  static absl::StatusOr<std::unique_ptr<Lms200Scanner>> Connect(const std::string& device,
                                                                const Lms200Options& options = {});
  // Asks the sensor to stop streaming (best effort: the cable may be gone).
  ~Lms200Scanner() override;
  Lms200Scanner(const Lms200Scanner&) = delete;
  Lms200Scanner& operator=(const Lms200Scanner&) = delete;

  LaserLayout layout() const override { return layout_; }
  // The next scan in metres. UNAVAILABLE when the device is unplugged or no scan came for
  // scan_timeout. Scans of the wrong beam count and anything else on the line are skipped.
  absl::StatusOr<LaserReading> Read() override;

  Lms200Stats stats() const;
  // The rate the link runs at (the sensor's and the host's).
  int baud() const { return port_->baud(); }

 private:
  Lms200Scanner(std::unique_ptr<SerialPort> port, const Lms200Options& options);

  absl::Status FindSensorRate();
  absl::Status SetVariant();
  absl::Status SwitchRate();
  absl::Status StartStreaming();
  // Sends `command_and_data` and waits for the telegram answering it (command | 0x80), resending
  // on timeout or NAK up to options_.retries times. Other telegrams meanwhile are skipped.
  absl::StatusOr<Lms200Telegram> Transact(const std::vector<std::uint8_t>& command_and_data,
                                          absl::Duration timeout, int attempts);
  // An A0 reply must carry 0x00 (accepted) first.
  absl::Status SwitchMode(const std::vector<std::uint8_t>& command_and_data, const char* what);
  // Reads what arrives within `timeout` into the parser. OK with nothing read on timeout.
  absl::Status Pump(absl::Duration timeout);
  // Starts afresh after a rate change (bytes at the old rate are noise), keeping the counts.
  void ResetParser();

  std::unique_ptr<SerialPort> port_;
  Lms200Options options_;
  LaserLayout layout_;
  Lms200Parser parser_;
  Lms200Stats counts_;  // the counters the parser does not keep
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_LMS200_SCANNER_H_
