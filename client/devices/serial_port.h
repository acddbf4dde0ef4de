#ifndef WAYMARK_CLIENT_DEVICES_SERIAL_PORT_H_
#define WAYMARK_CLIENT_DEVICES_SERIAL_PORT_H_

// A raw 8N1 serial port (termios): the link to the Pioneer's ARCOS controller and the SICK
// LMS200. Works on real UARTs, USB adapters and pseudo-terminals (the tests' fake peers).
//
// Errors name the device and what to do: NOT_FOUND (no such device), PERMISSION_DENIED (not in
// the dialout group), UNAVAILABLE (unplugged: EIO/ENXIO or a hang-up), INVALID_ARGUMENT (a baud
// rate termios does not have).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace waymark::adapters {

class SerialPort {
 public:
  static absl::StatusOr<std::unique_ptr<SerialPort>> Open(const std::string& path, int baud);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  // Changes the host side's rate after pending output has been sent.
  absl::Status SetBaud(int baud);
  int baud() const { return baud_; }

  // Reads what is available, waiting at most `timeout` for the first byte. Returns 0 bytes on
  // timeout; UNAVAILABLE once the device is gone.
  absl::StatusOr<std::size_t> Read(std::uint8_t* buffer, std::size_t capacity,
                                   absl::Duration timeout);
  // Writes all bytes (blocking) and waits until they left the host.
  absl::Status Write(const std::vector<std::uint8_t>& bytes);
  // Discards received bytes not yet read (after a baud change, say).
  void DiscardInput();

  const std::string& path() const { return path_; }

 private:
  SerialPort(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  absl::Status ErrnoStatus(const char* what, int error) const;

  std::string path_;
  int fd_ = -1;
  int baud_ = 0;
};

// Whether termios knows `baud` (the rates the devices use: 9600 .. 500000).
bool IsSupportedBaud(int baud);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DEVICES_SERIAL_PORT_H_
