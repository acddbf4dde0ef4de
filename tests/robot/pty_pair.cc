#include "tests/robot/pty_pair.h"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace waymark::testing {

absl::StatusOr<PtyPair> PtyPair::Open() {
  int master = -1, slave = -1;
  char name[256] = {0};
  if (openpty(&master, &slave, name, nullptr, nullptr) != 0) {
    return absl::UnavailableError(absl::StrCat("openpty: ", std::strerror(errno)));
  }
  // Raw on both ends: no echo, no line discipline touching the binary protocol.
  termios tio{};
  tcgetattr(slave, &tio);
  cfmakeraw(&tio);
  tcsetattr(slave, TCSANOW, &tio);
  fcntl(master, F_SETFD, FD_CLOEXEC);
  fcntl(slave, F_SETFD, FD_CLOEXEC);
  return PtyPair(master, slave, name);
}

PtyPair::PtyPair(PtyPair&& other) noexcept
    : master_fd_(other.master_fd_),
      slave_fd_(other.slave_fd_),
      device_path_(std::move(other.device_path_)) {
  other.master_fd_ = -1;
  other.slave_fd_ = -1;
}

PtyPair::~PtyPair() {
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
}

int PtyPair::host_baud() const {
  termios tio{};
  if (tcgetattr(slave_fd_ >= 0 ? slave_fd_ : master_fd_, &tio) != 0) return 0;
  switch (cfgetospeed(&tio)) {
    case B9600:
      return 9600;
    case B19200:
      return 19200;
    case B38400:
      return 38400;
    case B57600:
      return 57600;
    case B115200:
      return 115200;
    case B500000:
      return 500000;
    default:
      return 0;
  }
}

std::vector<std::uint8_t> PtyPair::ReadSome(absl::Duration timeout) const {
  std::vector<std::uint8_t> out;
  if (master_fd_ < 0) return out;
  pollfd p{master_fd_, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(absl::ToInt64Milliseconds(timeout))) <= 0) return out;
  std::uint8_t buffer[4096];
  const ssize_t n = ::read(master_fd_, buffer, sizeof(buffer));
  if (n > 0) out.assign(buffer, buffer + n);
  return out;
}

bool PtyPair::Write(const std::vector<std::uint8_t>& bytes) const {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(master_fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

void PtyPair::Hangup() {
  if (slave_fd_ >= 0) ::close(slave_fd_);
  slave_fd_ = -1;
  if (master_fd_ >= 0) ::close(master_fd_);
  master_fd_ = -1;
}

}  // namespace waymark::testing
