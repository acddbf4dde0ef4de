#ifndef WAYMARK_TESTS_ROBOT_PTY_PAIR_H_
#define WAYMARK_TESTS_ROBOT_PTY_PAIR_H_

// A pseudo-terminal pair standing in for a serial cable: the adapter under test opens
// `device_path()` like /dev/ttyS0, the fake peer reads and writes the master side.

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace waymark::testing {

class PtyPair {
 public:
  static absl::StatusOr<PtyPair> Open();
  PtyPair(PtyPair&& other) noexcept;
  PtyPair& operator=(PtyPair&&) = delete;
  PtyPair(const PtyPair&) = delete;
  ~PtyPair();

  const std::string& device_path() const { return device_path_; }
  int master_fd() const { return master_fd_; }

  // The baud rate the adapter set on its side (the pair shares one termios).
  int host_baud() const;
  // Reads what the adapter wrote, waiting at most `timeout` for the first byte.
  std::vector<std::uint8_t> ReadSome(absl::Duration timeout) const;
  bool Write(const std::vector<std::uint8_t>& bytes) const;
  // Closes the master: the adapter sees the cable unplugged.
  void Hangup();

 private:
  PtyPair(int master, int slave, std::string path)
      : master_fd_(master), slave_fd_(slave), device_path_(std::move(path)) {}
  int master_fd_ = -1;
  int slave_fd_ = -1;  // kept open so the pair survives until the adapter opens the device
  std::string device_path_;
};

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_ROBOT_PTY_PAIR_H_
