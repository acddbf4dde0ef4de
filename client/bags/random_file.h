#ifndef WAYMARK_CLIENT_BAGS_RANDOM_FILE_H_
#define WAYMARK_CLIENT_BAGS_RANDOM_FILE_H_

// A file read at offsets (pread), with its size taken at open. Every read is bounded by that size,
// so a length field that claims more than the file holds is an error before anything is
// allocated. pread rather than mmap: a bag still being written (or shrunk) under the reader gives
// a short read, not a SIGBUS.

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"

namespace waymark::bags {

class RandomFile {
 public:
  static absl::StatusOr<RandomFile> Open(const std::string& path);
  RandomFile(RandomFile&& other) noexcept;
  RandomFile& operator=(RandomFile&& other) noexcept;
  RandomFile(const RandomFile&) = delete;
  RandomFile& operator=(const RandomFile&) = delete;
  ~RandomFile();

  const std::string& path() const { return path_; }
  uint64_t size() const { return size_; }

  // Exactly `length` bytes at `offset`; OUT_OF_RANGE when they go past the end of the file.
  absl::StatusOr<std::string> Read(uint64_t offset, uint64_t length) const;
  // Up to `length` bytes at `offset` (fewer at the end of the file).
  absl::StatusOr<std::string> ReadUpTo(uint64_t offset, uint64_t length) const;

 private:
  RandomFile(std::string path, int fd, uint64_t size) : path_(std::move(path)), fd_(fd), size_(size) {}
  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
};

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_RANDOM_FILE_H_
