// waymark-bench-enroll: the cost of enrolling views in-process, as the database grows (36, 360,
// 3,600 views of real images from ../shared/data, reused cyclically with bench_images' augmentations
// beyond the number of sources): SIFT extraction per view on one and on all worker threads, and the
// paper's incremental clustering (ViewDatabase through EnrollView) against the quadratic reference
// (QuadraticClusters: brute force against every centre), in the same run, with the clusters
// compared. The end-to-end rate through the server (BulkEnroll) is waymark-bench-recognition's
// enroll_s.
//
//   waymark-bench-enroll --shared ../shared [--sizes 36,360,3600] [--runs 3] [--reference-max 3600]

#include <algorithm>
#include <atomic>
#include <chrono>
#include <ctime>
#include <iostream>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "bench/common/bench_images.h"
#include "bench/common/bench_timing.h"
#include "server/crossing/enrollment.h"
#include "server/crossing/features.h"
#include "server/crossing/view_database.h"

namespace waymark::bench {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

// View i: source i mod n, augmentation (i / n) mod kAugmentations, as JPEG (what a robot sends).
std::vector<std::string> MakeJpegs(const std::vector<std::string>& sources, int n) {
  std::vector<cv::Mat> originals;
  for (const auto& path : sources) originals.push_back(cv::imread(path, cv::IMREAD_COLOR));
  std::vector<std::string> jpegs;
  for (int i = 0; i < n; ++i) {
    const int s = i % static_cast<int>(sources.size());
    const int k = i / static_cast<int>(sources.size());
    std::vector<uchar> bytes;
    cv::imencode(".jpg", Augment(originals[s], k % kAugmentations), bytes,
                 {cv::IMWRITE_JPEG_QUALITY, 95});
    jpegs.emplace_back(bytes.begin(), bytes.end());
  }
  return jpegs;
}

// Extracts every view's features on `threads` threads; returns the wall seconds.
double ExtractAll(const std::vector<std::string>& jpegs, int threads,
                  std::vector<crossing::ImageFeatures>* out) {
  out->assign(jpegs.size(), {});
  std::atomic<size_t> next{0};
  const auto start = Clock::now();
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      for (size_t i = next++; i < jpegs.size(); i = next++) {
        auto f = crossing::ExtractFeatures(jpegs[i], crossing::FeatureOptions{});
        if (f.ok()) (*out)[i] = std::move(*f);
      }
    });
  }
  for (auto& w : workers) w.join();
  return Seconds(start, Clock::now());
}

// CPU seconds of the calling thread: the clustering is sequential, and on a shared machine its
// wall time says more about the other processes than about it.
double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + t.tv_nsec / 1e9;
}

struct Clustering {
  double seconds = 0;
  double cpu_seconds = 0;
  std::vector<crossing::ClusterEntry> clusters;
};

// The service's path: one view at a time, proposal against the centres so far, then the commit.
Clustering Incremental(const std::vector<crossing::ImageFeatures>& views, int n) {
  crossing::ViewDatabase db;
  const auto start = Clock::now();
  const double cpu = ThreadCpuSeconds();
  for (int i = 0; i < n; ++i) crossing::EnrollView(&db, i + 1, i / 12 + 1, 30.0 * (i % 12), views[i]);
  return {Seconds(start, Clock::now()), ThreadCpuSeconds() - cpu, db.clusters()};
}

Clustering Quadratic(const std::vector<crossing::ImageFeatures>& views, int n) {
  crossing::ViewDatabase db;
  for (int i = 0; i < n; ++i) {
    db.AddView(i + 1, i / 12 + 1, 30.0 * (i % 12), views[i].descriptors, {}, {});
  }
  const auto start = Clock::now();
  const double cpu = ThreadCpuSeconds();
  auto clusters = crossing::QuadraticClusters(db, crossing::ClusterOptions{});
  return {Seconds(start, Clock::now()), ThreadCpuSeconds() - cpu, std::move(clusters)};
}

bool SameClusters(const std::vector<crossing::ClusterEntry>& a,
                  const std::vector<crossing::ClusterEntry>& b) {
  if (a.size() != b.size()) return false;
  for (size_t c = 0; c < a.size(); ++c) {
    if (a[c].center != b[c].center || a[c].members != b[c].members) return false;
  }
  return true;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  std::string shared = "../shared";
  std::vector<int> sizes = {36, 360, 3600};
  int runs = 3, reference_max = 3600;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  CLI::App app{"In-process enrollment cost: SIFT extraction and the incremental clustering"};
  app.add_option("--shared", shared, "the shared data folder")->capture_default_str();
  app.add_option("--sizes", sizes, "database sizes in views")->delimiter(',')->capture_default_str();
  app.add_option("--runs", runs, "runs of the incremental clustering per size (median reported)")
      ->capture_default_str();
  app.add_option("--reference-max", reference_max,
                 "largest size the quadratic reference runs at (once per size)")
      ->capture_default_str();
  app.add_option("--threads", threads, "extraction threads for the parallel rate")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  using namespace waymark::bench;

  const auto sources = DatabaseSourceImages(shared);
  if (sources.empty()) {
    std::cerr << "no images under " << shared << "/data: this benchmark needs the shared data\n";
    return 2;
  }
  const int max_size = *std::max_element(sizes.begin(), sizes.end());
  std::cerr << "load average " << LoadAverageText() << "; " << max_size << " views from "
            << sources.size() << " real images\n";
  const auto jpegs = MakeJpegs(sources, max_size);
  std::vector<waymark::crossing::ImageFeatures> views;
  const int sample = std::min(max_size, 360);
  const double one_thread =
      ExtractAll(std::vector<std::string>(jpegs.begin(), jpegs.begin() + sample), 1, &views);
  const double parallel = ExtractAll(jpegs, threads, &views);
  double keypoints = 0;
  for (const auto& v : views) keypoints += v.descriptors.rows;
  fmt::print("SIFT extraction: {:.1f} views/s on 1 thread ({} views), {:.1f} views/s on {} threads "
             "({} views); {:.0f} keypoints per view\n",
             sample / one_thread, sample, max_size / parallel, threads, max_size,
             keypoints / views.size());

  fmt::print("views/s = views per wall second (per CPU second of the clustering thread)\n\n"
             "| views | clusters | incremental views/s (median of {}) | quadratic reference views/s | "
             "ratio (CPU) | same clusters |\n|---|---|---|---|---|---|\n",
             runs);
  for (int n : sizes) {
    std::vector<double> rates, cpu_rates;
    Clustering fast;
    for (int r = 0; r < runs; ++r) {
      fast = Incremental(views, n);
      rates.push_back(n / fast.seconds);
      cpu_rates.push_back(n / fast.cpu_seconds);
    }
    const double rate = Percentile(rates, 0.5), cpu_rate = Percentile(cpu_rates, 0.5);
    if (n <= reference_max) {
      const Clustering reference = Quadratic(views, n);
      const double cpu_reference = n / reference.cpu_seconds;
      fmt::print("| {} | {} | {:.1f} ({:.1f}) | {:.1f} ({:.1f}) | {:.1f}x | {} |\n", n,
                 fast.clusters.size(), rate, cpu_rate, n / reference.seconds, cpu_reference,
                 cpu_rate / cpu_reference,
                 SameClusters(fast.clusters, reference.clusters) ? "yes" : "NO");
    } else {
      fmt::print("| {} | {} | {:.1f} ({:.1f}) | - | - | - |\n", n, fast.clusters.size(), rate,
                 cpu_rate);
    }
    std::fflush(stdout);
  }
  std::cerr << "load average " << LoadAverageText() << "\n";
  return 0;
}
