// waymark-vo-detector-bench: milliseconds per frame of the visual odometry's detectors (the
// detector stage of METHODS.md section 3) on the Bonn crowd frames (640x480, 1-3 walking people).
//
//   waymark-vo-detector-bench [--shared ../shared] [--frames N] [--sizes 256,416]
//
// Rows: YOLO-Fastest 1.1 XL (../shared/models) at the cfg's input size, at 320 if that differs,
// and at each --sizes value; HOG people with its defaults. Each row runs once with OpenCV on one
// thread (cv::setNumThreads(1)) and once with OpenCV's default thread count. Frames are decoded
// before timing; only Detect() is timed (steady clock), after 3 untimed warm-up frames (the first
// forward passes allocate). Reported: median and p90 wall ms per frame, the median process CPU ms
// per frame (all threads; on a loaded machine the one-thread CPU time is close to what the wall
// time would be on an idle one) and the mean number of boxes. The load average is printed before
// and after: on a shared machine it says how much to trust the wall times. No asserts.

#include <stdlib.h>
#include <time.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "bench/common/bench_timing.h"
#include "server/visual_slam/detectors/detector_factory.h"

namespace waymark::bench {
namespace {

namespace fs = std::filesystem;
using visual_slam::DetectorChoice;

constexpr int kWarmup = 3;

struct Row {
  std::string detector;
  std::string input;
  DetectorChoice choice;
};

}  // namespace

int Main(int argc, char** argv) {
  CLI::App app{"Milliseconds per frame of the VO detectors on the Bonn crowd frames"};
  std::string shared = "../shared";
  int max_frames = 0;
  std::vector<int> extra_sizes;
  app.add_option("--shared", shared, "the shared data folder")->capture_default_str();
  app.add_option("--frames", max_frames, "use the first N frames (0 = all 140)");
  app.add_option("--sizes", extra_sizes, "more YOLO input sizes to time (multiples of 32)")
      ->delimiter(',');
  CLI11_PARSE(app, argc, argv);

  const fs::path frames_dir = fs::path(shared) / "data/vslam/bonn_rgbd_crowd_frames270-409/rgb";
  const fs::path model_dir = fs::path(shared) / "models/yolo-fastest-1.1-coco";
  if (!fs::is_directory(frames_dir) || !fs::exists(model_dir / "yolo-fastest-1.1-xl.weights")) {
    std::fprintf(stderr, "needs %s and %s (the shared data): not found\n", frames_dir.c_str(),
                 model_dir.c_str());
    return 1;
  }
  std::vector<fs::path> paths;
  for (const auto& entry : fs::directory_iterator(frames_dir)) {
    if (entry.path().extension() == ".png") paths.push_back(entry.path());
  }
  std::sort(paths.begin(), paths.end());
  if (max_frames > 0 && static_cast<size_t>(max_frames) < paths.size()) paths.resize(max_frames);
  std::vector<cv::Mat> frames;
  for (const auto& path : paths) frames.push_back(cv::imread(path.string(), cv::IMREAD_COLOR));
  if (frames.size() <= kWarmup) {
    std::fprintf(stderr, "too few frames in %s\n", frames_dir.c_str());
    return 1;
  }

  DetectorChoice yolo;
  yolo.kind = DetectorChoice::kYolo;
  yolo.yolo.cfg = ReadFileBytes(model_dir / "yolo-fastest-1.1-xl.cfg");
  yolo.yolo.weights = ReadFileBytes(model_dir / "yolo-fastest-1.1-xl.weights");
  // The cfg's [net] width (what input_size 0 means); 320 gets its own row only if it differs.
  int cfg_width = 0;
  if (const size_t at = yolo.yolo.cfg.find("\nwidth="); at != std::string::npos) {
    cfg_width = std::atoi(yolo.yolo.cfg.c_str() + at + 7);
  }
  std::vector<Row> rows = {{"yolo", std::to_string(cfg_width) + " (cfg)", yolo}};
  std::vector<int> sizes;
  if (cfg_width != 320) sizes.push_back(320);
  sizes.insert(sizes.end(), extra_sizes.begin(), extra_sizes.end());
  for (int size : sizes) {
    DetectorChoice sized = yolo;
    sized.yolo.input_size = size;
    rows.push_back({"yolo", std::to_string(size), sized});
  }
  DetectorChoice hog;
  hog.kind = DetectorChoice::kHog;
  rows.push_back({"hog", "640 max", hog});

  const int default_threads = cv::getNumThreads();
  std::printf("frames: %zu of %s (%dx%d), %d warm-up frames untimed\n", frames.size(),
              frames_dir.c_str(), frames[0].cols, frames[0].rows, kWarmup);
  std::printf("OpenCV default threads: %d; hardware threads: %u; load average before: %s\n\n",
              default_threads, std::thread::hardware_concurrency(), LoadAverageText().c_str());
  std::printf("%-8s %-10s %-8s %10s %10s %12s %12s\n", "detector", "input", "threads", "median ms",
              "p90 ms", "median cpu", "boxes/frame");
  for (const Row& row : rows) {
    auto detector = visual_slam::MakeDetector(row.choice);
    if (!detector.ok()) {
      std::printf("%-8s %-10s cannot build: %s\n", row.detector.c_str(), row.input.c_str(),
                  std::string(detector.status().message()).c_str());
      continue;
    }
    for (int threads : {1, default_threads}) {
      cv::setNumThreads(threads);
      std::vector<double> ms, cpu_ms;
      size_t boxes = 0;
      for (size_t i = 0; i < frames.size(); ++i) {
        const double cpu_start = ProcessCpuMs();
        const auto start = std::chrono::steady_clock::now();
        auto found = (*detector)->Detect(frames[i]);
        const auto stop = std::chrono::steady_clock::now();
        const double cpu = ProcessCpuMs() - cpu_start;
        if (!found.ok()) {
          std::fprintf(stderr, "frame %zu: %s\n", i, std::string(found.status().message()).c_str());
          continue;
        }
        if (i < kWarmup) continue;
        ms.push_back(std::chrono::duration<double, std::milli>(stop - start).count());
        cpu_ms.push_back(cpu);
        boxes += found->size();
      }
      std::printf("%-8s %-10s %-8d %10.1f %10.1f %12.1f %12.2f\n", row.detector.c_str(),
                  row.input.c_str(), threads, Percentile(ms, 0.5), Percentile(ms, 0.9),
                  Percentile(cpu_ms, 0.5),
                  ms.empty() ? 0.0 : static_cast<double>(boxes) / ms.size());
      if (threads == default_threads) break;  // one row when the default is one thread
    }
  }
  cv::setNumThreads(default_threads);
  std::printf("\nload average after: %s\n", LoadAverageText().c_str());
  return 0;
}

}  // namespace waymark::bench

int main(int argc, char** argv) { return waymark::bench::Main(argc, argv); }
