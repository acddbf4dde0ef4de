#ifndef WAYMARK_SERVER_CROSSING_DESCRIPTOR_INDEX_H_
#define WAYMARK_SERVER_CROSSING_DESCRIPTOR_INDEX_H_

// One nearest-neighbour index over the descriptors of every view of a database, so that a query
// costs about the same whether the database holds 36 views or 3,600 (a k-d tree per view, as the
// paper builds, costs a search per view).
//
// It grows as views are enrolled without rebuilding everything: descriptors live in an
// append-only DescriptorStore and the index is a short list of k-d forests ("levels") over
// consecutive id ranges. A new view gets a level of its own; whenever the newest level reaches a
// quarter of the one before, the two are merged (rebuilt as one). That keeps O(log n) levels and
// rebuilds each descriptor O(log n) times over the life of the database.

#include <cstdint>
#include <memory>
#include <vector>

#include "server/crossing/descriptor_store.h"
#include "server/crossing/kd_forest.h"
#include "server/crossing/options.h"

namespace waymark::crossing {

class DescriptorIndex {
 public:
  explicit DescriptorIndex(const IndexOptions& options) : options_(options) {}

  // Appends `count` descriptors of view slot `view` and indexes them. Returns the first id.
  uint32_t Add(const uint8_t* descriptors, uint32_t count, uint32_t view);
  // Appends without indexing: for bulk loads, which call Compact() once at the end. Descriptors
  // appended this way are not searched until then.
  uint32_t AddUnindexed(const uint8_t* descriptors, uint32_t count, uint32_t view) {
    return store_.Append(descriptors, count, view);
  }
  // Rebuilds all levels as one forest over everything stored.
  void Compact();

  // The `knn` nearest stored descriptors of `query` (approximate: `checks` descriptors visited,
  // shared over the levels in proportion to their size).
  // With `view_filter`, only views v with (*view_filter)[v] != 0 are searched (clustering asks
  // for cluster centres only) and the search budget is larger.
  void Search(const uint8_t* query, KnnList* result,
              const std::vector<uint8_t>* view_filter = nullptr) const;

  const DescriptorStore& store() const { return store_; }
  const IndexOptions& options() const { return options_; }
  size_t levels() const { return levels_.size(); }
  size_t memory_bytes() const;  // forests + labels, not the descriptors themselves

 private:
  void MergeLevels();

  IndexOptions options_;
  DescriptorStore store_;
  std::vector<std::unique_ptr<KdForest>> levels_;
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_DESCRIPTOR_INDEX_H_
