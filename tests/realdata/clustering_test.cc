// The paper's clustering on real images: every image of ../shared/data/vpr (the corridor and the
// Gardens Point / SFU triplets, read in place; skipped when absent), enrolled one by one, makes
// exactly the clusters of the quadratic reference (every view matched by brute force against every
// centre in enrollment order): same centres, same members, same order.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "server/crossing/enrollment.h"
#include "server/crossing/features.h"
#include "server/crossing/view_database.h"

namespace waymark::crossing {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> VprImages() {
  std::vector<std::string> files;
  const fs::path root = fs::path(WAYMARK_SHARED_DIR) / "data/vpr";
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    const std::string ext = e.path().extension().string();
    if (ext == ".jpg" || ext == ".png" || ext == ".jpeg") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(RealClusteringTest, IncrementalClusteringEqualsQuadraticOnVprImages) {
  const std::vector<std::string> files = VprImages();
  if (files.empty()) GTEST_SKIP() << "no images under ../shared/data/vpr";
  std::vector<ImageFeatures> features(files.size());
  std::atomic<size_t> next{0};
  std::vector<std::thread> workers;
  for (int t = 0; t < 2; ++t) {
    workers.emplace_back([&] {
      for (size_t i = next++; i < files.size(); i = next++) {
        const cv::Mat image = cv::imread(files[i], cv::IMREAD_COLOR);
        auto f = ExtractSift(ToWorkingResolution(image, FeatureOptions{}), FeatureOptions{});
        if (f.ok()) features[i] = std::move(*f);
      }
    });
  }
  for (auto& w : workers) w.join();

  ViewDatabase db;
  for (size_t i = 0; i < features.size(); ++i) {
    EnrollView(&db, static_cast<int64_t>(i) + 1, 1, 0, features[i]);
  }
  const std::vector<ClusterEntry> reference = QuadraticClusters(db, ClusterOptions{});
  for (const auto& clusters : {db.clusters(), db.ComputeClusters(ClusterOptions{})}) {
    ASSERT_EQ(clusters.size(), reference.size());
    for (size_t c = 0; c < clusters.size(); ++c) {
      EXPECT_EQ(clusters[c].center, reference[c].center) << "cluster " << c;
      EXPECT_EQ(clusters[c].members, reference[c].members) << "cluster " << c;
    }
  }
  // Real structure, not one cluster per view: revisited places join their centres.
  EXPECT_GT(files.size(), 200u);
  EXPECT_LT(reference.size(), files.size() * 9 / 10);
}

}  // namespace
}  // namespace waymark::crossing
