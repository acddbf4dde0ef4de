#include "server/crossing/descriptor_index.h"

#include <algorithm>

namespace waymark::crossing {
namespace {

// A level gets at least this many checks, however small, so that a just-enrolled view is found.
constexpr int kMinChecksPerLevel = 32;
// Merge the newest level into the previous when it reaches 1/kMergeRatio of its size.
constexpr uint32_t kMergeRatio = 4;
// A filtered search skips most of what it visits, so it gets a larger budget.
constexpr int kFilteredChecksFactor = 4;

}  // namespace

uint32_t DescriptorIndex::Add(const uint8_t* descriptors, uint32_t count, uint32_t view) {
  const uint32_t first = store_.Append(descriptors, count, view);
  if (count == 0) return first;
  levels_.push_back(std::make_unique<KdForest>(store_, first, first + count, options_.trees,
                                               options_.leaf_size, first));
  MergeLevels();
  return first;
}

void DescriptorIndex::MergeLevels() {
  while (levels_.size() >= 2) {
    const KdForest& last = *levels_[levels_.size() - 1];
    const KdForest& previous = *levels_[levels_.size() - 2];
    if (last.size() * kMergeRatio < previous.size()) break;
    const uint32_t begin = previous.begin(), end = last.end();
    levels_.pop_back();
    levels_.back() = std::make_unique<KdForest>(store_, begin, end, options_.trees,
                                                options_.leaf_size, begin);
  }
}

void DescriptorIndex::Compact() {
  levels_.clear();
  if (store_.size() == 0) return;
  levels_.push_back(std::make_unique<KdForest>(store_, 0, store_.size(), options_.trees,
                                               options_.leaf_size, 0));
}

void DescriptorIndex::Search(const uint8_t* query, KnnList* result,
                             const std::vector<uint8_t>* view_filter) const {
  const double total = std::max<uint32_t>(1, store_.size());
  const double budget = options_.checks * (view_filter != nullptr ? kFilteredChecksFactor : 1);
  for (const auto& level : levels_) {
    const int checks =
        std::max(kMinChecksPerLevel, static_cast<int>(budget * (level->size() / total)));
    level->Search(query, checks, result, view_filter);
  }
}

size_t DescriptorIndex::memory_bytes() const {
  size_t bytes = static_cast<size_t>(store_.size()) * sizeof(uint32_t);
  for (const auto& level : levels_) bytes += level->memory_bytes();
  return bytes;
}

}  // namespace waymark::crossing
