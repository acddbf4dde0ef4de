#ifndef WAYMARK_SERVER_CROSSING_DESCRIPTOR_INDEX_H_
#define WAYMARK_SERVER_CROSSING_DESCRIPTOR_INDEX_H_

// One nearest-neighbour index over the descriptors of every view of a database, so that a query
// costs about the same whether the database holds 36 views or 3,600 (a k-d tree per view, as the
// paper builds, costs a search per view).
//
// It grows as views are enrolled without rebuilding everything: descriptors live in an
// append-only DescriptorStore and a ForestSet is a short list of k-d forests ("levels") over sets
// of their ids. New ids get a level of their own; whenever the newest level reaches a quarter of
// the one before, the two are merged (rebuilt as one). That keeps O(log n) levels and rebuilds
// each descriptor O(log n) times over the life of the database. The search is approximate, so
// its results depend on the trees: the levels are a pure function of the sequence of additions
// (and their seeds of the ids), never of timing, which is what makes a restart reproducible.

#include <cstdint>
#include <memory>
#include <vector>

#include "server/crossing/descriptor_store.h"
#include "server/crossing/kd_forest.h"
#include "server/crossing/options.h"

namespace waymark::crossing {

// A searchable set of ids of a DescriptorStore. Several sets can index the same store without
// copying it (all descriptors; the cluster centres' descriptors).
class ForestSet {
 public:
  ForestSet(const DescriptorStore& store, const IndexOptions& options)
      : store_(store), options_(options) {}
  ForestSet(const ForestSet&) = delete;
  ForestSet& operator=(const ForestSet&) = delete;

  // Indexes more ids (a new level, merged as described above). With `defer_build` the levels
  // are only planned: loading replays every addition this way, then builds the final levels
  // once (BuildPending), which gives the same forests as building along the way at a fraction
  // of the cost. Unbuilt levels are not searched.
  void Add(std::vector<uint32_t> ids, bool defer_build = false);
  void BuildPending();
  void Clear() {
    levels_.clear();
    size_ = 0;
  }

  // The `knn` nearest indexed descriptors of `query` (approximate: `checks` descriptors visited,
  // shared over the levels in proportion to their size).
  void Search(const uint8_t* query, KnnList* result) const;

  const DescriptorStore& store() const { return store_; }
  const IndexOptions& options() const { return options_; }
  size_t levels() const { return levels_.size(); }
  size_t size() const { return size_; }
  size_t memory_bytes() const;

 private:
  struct Level {
    std::vector<uint32_t> ids;  // sorted; only until the forest is built (it keeps them)
    size_t size = 0;
    uint32_t seed = 0;
    std::unique_ptr<KdForest> forest;  // null until built
  };
  // The level's ids in ascending order, leaving the level empty.
  static std::vector<uint32_t> TakeIds(Level* level);

  const DescriptorStore& store_;
  IndexOptions options_;
  std::vector<Level> levels_;
  size_t size_ = 0;
};

// The store of all descriptors of a database and the forests over all of them.
class DescriptorIndex {
 public:
  explicit DescriptorIndex(const IndexOptions& options) : all_(store_, options) {}
  DescriptorIndex(const DescriptorIndex&) = delete;
  DescriptorIndex& operator=(const DescriptorIndex&) = delete;

  // Appends `count` descriptors of view slot `view` and indexes them. Returns the first id.
  // The forests depend only on the sequence of Add calls, so a database reloaded by adding its
  // views in enrollment order searches exactly as before the restart. `defer_build`: see
  // ForestSet::Add; call BuildPending() before searching.
  uint32_t Add(const uint8_t* descriptors, uint32_t count, uint32_t view,
               bool defer_build = false);
  void BuildPending() { all_.BuildPending(); }

  void Search(const uint8_t* query, KnnList* result) const { all_.Search(query, result); }

  const DescriptorStore& store() const { return store_; }
  const ForestSet& forests() const { return all_; }
  const IndexOptions& options() const { return all_.options(); }
  size_t levels() const { return all_.levels(); }
  size_t memory_bytes() const;  // forests + labels, not the descriptors themselves

 private:
  DescriptorStore store_;
  ForestSet all_;
};

// Ids [first, first + count).
std::vector<uint32_t> IdRange(uint32_t first, uint32_t count);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_DESCRIPTOR_INDEX_H_
