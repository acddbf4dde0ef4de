// Micro-benchmarks of the recognition engine's hot paths (Google Benchmark). Compare within one
// run: e.g. BM_MatchAllViews (index) against BM_MatchEveryViewExact (linear scan) at the same size.

#include <numeric>
#include <random>

#include <benchmark/benchmark.h>
#include <opencv2/imgproc.hpp>

#include "server/crossing/dense_sift.h"
#include "server/crossing/descriptor_index.h"
#include "server/crossing/global_index.h"
#include "server/crossing/vlad.h"
#include "server/crossing/features.h"
#include "server/crossing/hue_histogram.h"
#include "server/crossing/kd_forest.h"
#include "server/crossing/descriptor_store.h"
#include "server/crossing/l2_distance.h"
#include "server/crossing/view_matching.h"
#include "tests/support/random_descriptors.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::crossing {
namespace {

using waymark::testing::RandomDescriptors;

void BM_SquaredL2(benchmark::State& state) {
  std::mt19937 rng(1);
  const cv::Mat d = RandomDescriptors(2, &rng);
  for (auto _ : state) benchmark::DoNotOptimize(SquaredL2(d.ptr<uint8_t>(0), d.ptr<uint8_t>(1)));
}
BENCHMARK(BM_SquaredL2);

void BM_ExtractSift(benchmark::State& state) {
  const cv::Mat view = testing::CropView(testing::MakePanorama(3), 90);
  for (auto _ : state) benchmark::DoNotOptimize(ExtractSift(view, FeatureOptions{}));
}
BENCHMARK(BM_ExtractSift)->Unit(benchmark::kMillisecond);

void BM_HueHistogram(benchmark::State& state) {
  const cv::Mat view = testing::CropView(testing::MakePanorama(3), 90);
  for (auto _ : state) benchmark::DoNotOptimize(HueHistogram(view, 36));
}
BENCHMARK(BM_HueHistogram)->Unit(benchmark::kMicrosecond);

// A database of state.range(0) views of 300 descriptors, queried with 300 descriptors of which
// 100 are near copies of one view's.
struct Fixture {
  explicit Fixture(int views) : index(IndexOptions{}) {
    std::mt19937 rng(2);
    for (int v = 0; v < views; ++v) {
      const cv::Mat d = RandomDescriptors(300, &rng);
      spans.push_back(ViewSpan{index.Add(d.ptr<uint8_t>(), 300, v), 300});
      if (v == views / 2) query = d.rowRange(0, 100).clone();
    }
    query.push_back(RandomDescriptors(200, &rng));
  }
  DescriptorIndex index;
  std::vector<ViewSpan> spans;
  cv::Mat query;
};

void BM_MatchAllViews(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(MatchAllViews(f.query, f.index, f.spans, 0.32, true));
}
BENCHMARK(BM_MatchAllViews)->Arg(36)->Arg(360)->Arg(3600)->Unit(benchmark::kMillisecond);

void BM_MatchEveryViewExact(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    for (const ViewSpan& span : f.spans) {
      benchmark::DoNotOptimize(MatchViewExact(f.query, f.index.store(), span, 0.32));
    }
  }
}
BENCHMARK(BM_MatchEveryViewExact)->Arg(36)->Arg(360)->Unit(benchmark::kMillisecond);

// Building one k-d forest (IndexOptions' trees and leaf size) over state.range(0) descriptors:
// what a merge of the index's levels costs, under the database's lock, during enrollment.
void BM_BuildForest(benchmark::State& state) {
  std::mt19937 rng(5);
  DescriptorStore store;
  const int n = static_cast<int>(state.range(0));
  const cv::Mat d = RandomDescriptors(n, &rng);
  store.Append(d.ptr<uint8_t>(), static_cast<uint32_t>(n), 0);
  std::vector<uint32_t> ids(n);
  std::iota(ids.begin(), ids.end(), 0u);
  const IndexOptions options;
  for (auto _ : state) {
    KdForest forest(store, ids, options.trees, options.leaf_size, 1);
    benchmark::DoNotOptimize(forest.size());
  }
}
BENCHMARK(BM_BuildForest)->Arg(100000)->Unit(benchmark::kMillisecond);

// The retrieval mode's global stage per query: dense RootSIFT, VLAD encoding over 128 words, and
// the 8-bit scan over state.range(0) views.
cv::Mat GreyWorkingView() {
  cv::Mat grey;
  cv::cvtColor(testing::CropView(testing::MakePanorama(3), 90), grey, cv::COLOR_BGR2GRAY);
  return grey;
}

void BM_DenseRootSift(benchmark::State& state) {
  const cv::Mat grey = GreyWorkingView();
  for (auto _ : state) benchmark::DoNotOptimize(DenseRootSift(grey));
}
BENCHMARK(BM_DenseRootSift)->Unit(benchmark::kMillisecond);

void BM_VladEncode(benchmark::State& state) {
  const cv::Mat dense = DenseRootSift(GreyWorkingView());
  const VladVocabulary vocabulary = VladVocabulary::Train(dense, kVladWords);
  for (auto _ : state) benchmark::DoNotOptimize(vocabulary.Encode(dense));
}
BENCHMARK(BM_VladEncode)->Unit(benchmark::kMillisecond);

void BM_GlobalScan(benchmark::State& state) {
  std::mt19937 rng(3);
  std::normal_distribution<float> normal;
  const int dims = kVladWords * kDescriptorSize;
  auto random_code = [&] {
    cv::Mat v(1, dims, CV_32F);
    for (int i = 0; i < dims; ++i) v.at<float>(i) = normal(rng);
    return QuantizeGlobal(v);
  };
  GlobalIndex index;
  index.Reset(dims);
  for (int slot = 0; slot < state.range(0); ++slot) index.Set(slot, random_code());
  const GlobalCode query = random_code();
  for (auto _ : state) benchmark::DoNotOptimize(index.Similarities(query));
}
BENCHMARK(BM_GlobalScan)->Arg(36)->Arg(360)->Arg(3600)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace waymark::crossing

BENCHMARK_MAIN();
