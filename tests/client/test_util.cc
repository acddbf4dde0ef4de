#include "tests/client/test_util.h"

#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
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

cv::Mat BlockFrame(int shift) {
  cv::Mat blocks(30, 40, CV_8UC1);
  cv::RNG rng(18);
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::Mat grey;
  cv::resize(blocks, grey, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);
  cv::Mat shifted = grey;
  const int s = ((shift % grey.cols) + grey.cols) % grey.cols;
  if (s > 0) {
    cv::hconcat(grey.colRange(grey.cols - s, grey.cols), grey.colRange(0, grey.cols - s), shifted);
  }
  cv::Mat frame;
  cv::cvtColor(shifted, frame, cv::COLOR_GRAY2BGR);
  return frame;
}

void WriteVideo(const fs::path& path, const std::vector<cv::Mat>& frames, double fps) {
  fs::create_directories(path.parent_path());
  cv::VideoWriter writer(path.string(), cv::CAP_OPENCV_MJPEG,
                         cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, frames.front().size());
  if (!writer.isOpened()) throw std::runtime_error("cv::VideoWriter failed for " + path.string());
  for (const cv::Mat& frame : frames) writer.write(frame);
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
