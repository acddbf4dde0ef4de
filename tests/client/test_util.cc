#include "tests/client/test_util.h"

#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

#include "client/cli/cli.h"

namespace waymark::testing {

namespace fs = std::filesystem;

ScopedTempDir::ScopedTempDir() {
  std::random_device random;
  for (int attempt = 0; attempt < 100; ++attempt) {
    fs::path candidate =
        fs::temp_directory_path() / ("waymark_client_test_" + std::to_string(random()));
    if (fs::create_directory(candidate)) {
      path_ = candidate;
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary directory");
}

ScopedTempDir::~ScopedTempDir() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

fs::path ScopedTempDir::Make(const std::string& relative) const {
  fs::path full = path_ / relative;
  fs::create_directories(full.parent_path());
  return full;
}

void WriteImage(const fs::path& path, int width, int height, cv::Scalar color) {
  cv::Mat image(height, width, CV_8UC3, color);
  cv::line(image, {0, 0}, {width - 1, height - 1}, cv::Scalar(255, 255, 255), 3);
  fs::create_directories(path.parent_path());
  if (!cv::imwrite(path.string(), image)) {
    throw std::runtime_error("cv::imwrite failed for " + path.string());
  }
}

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

CliResult RunWaymark(const std::string& server, std::vector<std::string> args) {
  args.insert(args.begin(), {"waymark", "--server", server});
  std::vector<const char*> argv;
  for (const std::string& arg : args) argv.push_back(arg.c_str());
  std::ostringstream out, err;
  CliResult result;
  result.code = cli::RunCli(static_cast<int>(argv.size()), argv.data(), out, err, false);
  result.out = out.str();
  result.err = err.str();
  return result;
}

}  // namespace waymark::testing
