#include "server/crossing/descriptor_index.h"

#include <algorithm>
#include <numeric>

namespace waymark::crossing {
namespace {

// A level gets at least this many checks, however small, so that a just-enrolled view is found.
constexpr int kMinChecksPerLevel = 32;
// Merge the newest level into the previous when it reaches 1/kMergeRatio of its size.
constexpr uint32_t kMergeRatio = 4;

}  // namespace

std::vector<uint32_t> IdRange(uint32_t first, uint32_t count) {
  std::vector<uint32_t> ids(count);
  std::iota(ids.begin(), ids.end(), first);
  return ids;
}

void ForestSet::Add(std::vector<uint32_t> ids) {
  if (ids.empty()) return;
  size_ += ids.size();
  const uint32_t seed = ids.front();
  levels_.push_back(std::make_unique<KdForest>(store_, std::move(ids), options_.trees,
                                               options_.leaf_size, seed));
  while (levels_.size() >= 2) {
    const KdForest& last = *levels_[levels_.size() - 1];
    const KdForest& previous = *levels_[levels_.size() - 2];
    if (last.size() * kMergeRatio < previous.size()) break;
    std::vector<uint32_t> merged = previous.ids();
    merged.insert(merged.end(), last.ids().begin(), last.ids().end());
    std::sort(merged.begin(), merged.end());  // deterministic trees whatever the merge history
    levels_.pop_back();
    levels_.back() = std::make_unique<KdForest>(store_, std::move(merged), options_.trees,
                                                options_.leaf_size, seed);
  }
}

void ForestSet::Search(const uint8_t* query, KnnList* result) const {
  const double total = std::max<size_t>(1, size_);
  for (const auto& level : levels_) {
    const int checks = std::max(kMinChecksPerLevel,
                                static_cast<int>(options_.checks * (level->size() / total)));
    level->Search(query, checks, result);
  }
}

size_t ForestSet::memory_bytes() const {
  size_t bytes = 0;
  for (const auto& level : levels_) bytes += level->memory_bytes();
  return bytes;
}

uint32_t DescriptorIndex::Add(const uint8_t* descriptors, uint32_t count, uint32_t view) {
  const uint32_t first = store_.Append(descriptors, count, view);
  all_.Add(IdRange(first, count));
  return first;
}

size_t DescriptorIndex::memory_bytes() const {
  return static_cast<size_t>(store_.size()) * sizeof(uint32_t) + all_.memory_bytes();
}

}  // namespace waymark::crossing
