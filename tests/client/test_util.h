#ifndef WAYMARK_TESTS_CLIENT_TEST_UTIL_H_
#define WAYMARK_TESTS_CLIENT_TEST_UTIL_H_

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace waymark::testing {

// A fresh directory under the system temp dir, removed with everything in it on destruction.
class ScopedTempDir {
 public:
  ScopedTempDir();
  ~ScopedTempDir();
  ScopedTempDir(const ScopedTempDir&) = delete;
  ScopedTempDir& operator=(const ScopedTempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // path() / relative, with parent directories created.
  std::filesystem::path Make(const std::string& relative) const;

 private:
  std::filesystem::path path_;
};

// Writes a real image (format from the extension) of the given size: a solid colour plus a
// diagonal line, so that differently coloured images have different bytes.
void WriteImage(const std::filesystem::path& path, int width, int height, cv::Scalar color);

std::string ReadAll(const std::filesystem::path& path);

// A 320x240 frame of sharp 8-pixel blocks of random grey (fixed seed), shifted right by `shift`
// pixels (wrapping): frames with shifts far apart differ everywhere.
cv::Mat BlockFrame(int shift);

// Writes `frames` as a Motion-JPEG AVI (OpenCV's own writer, no codec library needed) at `fps`.
void WriteVideo(const std::filesystem::path& path, const std::vector<cv::Mat>& frames, double fps);

// The outcome of one `waymark` command line run in process.
struct CliResult {
  int code = -1;
  std::string out;
  std::string err;

  nlohmann::json Json() const { return nlohmann::json::parse(out); }
};

// Runs `waymark --server SERVER ARGS...` through cli::RunCli (stderr not a terminal).
CliResult RunWaymark(const std::string& server, std::vector<std::string> args);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_CLIENT_TEST_UTIL_H_
