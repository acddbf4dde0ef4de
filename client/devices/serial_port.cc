#include "client/devices/serial_port.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace waymark::adapters {
namespace {

speed_t SpeedConstant(int baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 500000:
      return B500000;
    default:
      return 0;
  }
}

}  // namespace

bool IsSupportedBaud(int baud) { return SpeedConstant(baud) != 0; }

absl::Status SerialPort::ErrnoStatus(const char* what, int error) const {
  const std::string message = absl::StrCat(what, " ", path_, ": ", std::strerror(error));
  switch (error) {
    case ENOENT:
    case ENODEV:
      return absl::NotFoundError(absl::StrCat(message, " (is the cable plugged in?)"));
    case EACCES:
    case EPERM:
      return absl::PermissionDeniedError(
          absl::StrCat(message, " (add the user to the dialout group)"));
    case EIO:
    case ENXIO:
      return absl::UnavailableError(absl::StrCat(message, " (device disconnected)"));
    default:
      return absl::UnavailableError(message);
  }
}

absl::StatusOr<std::unique_ptr<SerialPort>> SerialPort::Open(const std::string& path, int baud) {
  if (!IsSupportedBaud(baud)) {
    return absl::InvalidArgumentError(absl::StrCat("unsupported baud rate ", baud));
  }
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  std::unique_ptr<SerialPort> port(new SerialPort(path, fd));
  if (fd < 0) return port->ErrnoStatus("cannot open", errno);
  termios tio{};
  if (tcgetattr(fd, &tio) != 0) return port->ErrnoStatus("not a serial port:", errno);
  cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~(CSTOPB | PARENB | CRTSCTS);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (tcsetattr(fd, TCSANOW, &tio) != 0) return port->ErrnoStatus("cannot configure", errno);
  if (absl::Status s = port->SetBaud(baud); !s.ok()) return s;
  tcflush(fd, TCIOFLUSH);
  return port;
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

absl::Status SerialPort::SetBaud(int baud) {
  const speed_t speed = SpeedConstant(baud);
  if (speed == 0) return absl::InvalidArgumentError(absl::StrCat("unsupported baud rate ", baud));
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0) return ErrnoStatus("cannot read settings of", errno);
  cfsetispeed(&tio, speed);
  cfsetospeed(&tio, speed);
  // TCSADRAIN: a command sent at the old rate must leave before the rate changes.
  if (tcsetattr(fd_, TCSADRAIN, &tio) != 0) return ErrnoStatus("cannot set baud rate of", errno);
  baud_ = baud;
  return absl::OkStatus();
}

absl::StatusOr<std::size_t> SerialPort::Read(std::uint8_t* buffer, std::size_t capacity,
                                             absl::Duration timeout) {
  pollfd p{fd_, POLLIN, 0};
  const int ms = static_cast<int>(std::max<int64_t>(0, absl::ToInt64Milliseconds(timeout)));
  int ready;
  do {
    ready = ::poll(&p, 1, ms);
  } while (ready < 0 && errno == EINTR);
  if (ready < 0) return ErrnoStatus("cannot poll", errno);
  if (ready == 0) return 0;
  if ((p.revents & POLLIN) == 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) {
    return absl::UnavailableError(absl::StrCat(path_, " hung up (device disconnected)"));
  }
  ssize_t n;
  do {
    n = ::read(fd_, buffer, capacity);
  } while (n < 0 && errno == EINTR);
  if (n < 0) {
    if (errno == EAGAIN) return 0;
    return ErrnoStatus("cannot read", errno);
  }
  if (n == 0 && (p.revents & POLLHUP) != 0) {
    return absl::UnavailableError(absl::StrCat(path_, " hung up (device disconnected)"));
  }
  return static_cast<std::size_t>(n);
}

absl::Status SerialPort::Write(const std::vector<std::uint8_t>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN) {
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, 100);
        continue;
      }
      return ErrnoStatus("cannot write", errno);
    }
    done += static_cast<std::size_t>(n);
  }
  // A pseudo-terminal may not implement tcdrain's wait; ignore its result there.
  tcdrain(fd_);
  return absl::OkStatus();
}

void SerialPort::DiscardInput() { tcflush(fd_, TCIFLUSH); }

}  // namespace waymark::adapters
