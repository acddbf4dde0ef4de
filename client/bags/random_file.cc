#include "client/bags/random_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace waymark::bags {

absl::StatusOr<RandomFile> RandomFile::Open(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    const std::string message = absl::StrCat(path, ": ", std::strerror(error));
    if (error == ENOENT) return absl::NotFoundError(message);
    if (error == EACCES) return absl::PermissionDeniedError(message);
    return absl::InvalidArgumentError(message);
  }
  struct stat info {};
  if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    ::close(fd);
    return absl::InvalidArgumentError(absl::StrCat(path, ": not a regular file"));
  }
  return RandomFile(path, fd, static_cast<uint64_t>(info.st_size));
}

RandomFile::RandomFile(RandomFile&& other) noexcept
    : path_(std::move(other.path_)), fd_(other.fd_), size_(other.size_) {
  other.fd_ = -1;
}

RandomFile& RandomFile::operator=(RandomFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = other.fd_;
    size_ = other.size_;
    other.fd_ = -1;
  }
  return *this;
}

RandomFile::~RandomFile() {
  if (fd_ >= 0) ::close(fd_);
}

absl::StatusOr<std::string> RandomFile::ReadUpTo(uint64_t offset, uint64_t length) const {
  if (offset >= size_) return std::string();
  if (length > size_ - offset) length = size_ - offset;
  std::string out(length, '\0');
  uint64_t done = 0;
  while (done < length) {
    const ssize_t n = ::pread(fd_, out.data() + done, length - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      return absl::DataLossError(absl::StrCat(path_, ": read error: ", std::strerror(errno)));
    }
    if (n == 0) break;  // the file shrank since it was opened
    done += static_cast<uint64_t>(n);
  }
  out.resize(done);
  return out;
}

absl::StatusOr<std::string> RandomFile::Read(uint64_t offset, uint64_t length) const {
  if (offset > size_ || length > size_ - offset) {
    return absl::OutOfRangeError(absl::StrCat(path_, ": ", length, " bytes at offset ", offset,
                                              " go past the end of the file (", size_, " bytes)"));
  }
  absl::StatusOr<std::string> bytes = ReadUpTo(offset, length);
  if (bytes.ok() && bytes->size() != length) {
    return absl::OutOfRangeError(absl::StrCat(path_, ": the file ended at offset ",
                                              offset + bytes->size(), " while reading ", length,
                                              " bytes at ", offset));
  }
  return bytes;
}

}  // namespace waymark::bags
