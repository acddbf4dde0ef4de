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

void ForestSet::Add(std::vector<uint32_t> ids, bool defer_build) {
  if (ids.empty()) return;
  size_ += ids.size();
  const uint32_t seed = ids.front();
  const size_t count = ids.size();
  levels_.push_back(Level{std::move(ids), count, seed, nullptr});
  while (levels_.size() >= 2) {
    Level& last = levels_[levels_.size() - 1];
    Level& previous = levels_[levels_.size() - 2];
    if (last.size * kMergeRatio < previous.size) break;
    std::vector<uint32_t> merged = TakeIds(&previous);
    const std::vector<uint32_t> newer = TakeIds(&last);
    merged.insert(merged.end(), newer.begin(), newer.end());
    // Deterministic trees whatever the merge history (ids mostly arrive in order already).
    if (!std::is_sorted(merged.begin(), merged.end())) std::sort(merged.begin(), merged.end());
    previous.size = merged.size();
    previous.ids = std::move(merged);
    previous.seed = seed;
    levels_.pop_back();
  }
  if (!defer_build) BuildPending();
}

std::vector<uint32_t> ForestSet::TakeIds(Level* level) {
  std::vector<uint32_t> ids;
  if (level->forest != nullptr) {
    ids = level->forest->ids();  // a permutation: sort it back
    std::sort(ids.begin(), ids.end());
    level->forest.reset();
  } else {
    ids = std::move(level->ids);
  }
  return ids;
}

void ForestSet::BuildPending() {
  for (Level& level : levels_) {
    if (level.forest == nullptr) {
      // The forest keeps the ids (in tree order); the level's copy is no longer needed.
      level.forest = std::make_unique<KdForest>(store_, std::move(level.ids), options_.trees,
                                                options_.leaf_size, level.seed);
      level.ids = {};
    }
  }
}

void ForestSet::Search(const uint8_t* query, KnnList* result) const {
  const double total = std::max<size_t>(1, size_);
  for (const Level& level : levels_) {
    if (level.forest == nullptr) continue;
    const int checks = std::max(
        kMinChecksPerLevel, static_cast<int>(options_.checks * (level.size / total)));
    level.forest->Search(query, checks, result);
  }
}

size_t ForestSet::memory_bytes() const {
  size_t bytes = 0;
  for (const Level& level : levels_) {
    bytes += level.ids.capacity() * sizeof(uint32_t);
    if (level.forest != nullptr) bytes += level.forest->memory_bytes();
  }
  return bytes;
}

uint32_t DescriptorIndex::Add(const uint8_t* descriptors, uint32_t count, uint32_t view,
                              bool defer_build) {
  const uint32_t first = store_.Append(descriptors, count, view);
  all_.Add(IdRange(first, count), defer_build);
  return first;
}

size_t DescriptorIndex::memory_bytes() const {
  return store_.label_bytes() + all_.memory_bytes();
}

}  // namespace waymark::crossing
