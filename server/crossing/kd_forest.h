#ifndef WAYMARK_SERVER_CROSSING_KD_FOREST_H_
#define WAYMARK_SERVER_CROSSING_KD_FOREST_H_

// Randomized k-d trees (Silpa-Anan & Hartley 2008, the structure behind FLANN's KDTreeIndex) over
// a set of descriptor ids of a DescriptorStore, searched best-bin-first. Written here rather than
// taken from cv::flann because FLANN wants float data (4x the memory of the uint8 descriptors) and
// cannot grow; this one indexes the uint8 store in place.

#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "server/crossing/descriptor_store.h"

namespace waymark::crossing {

struct Neighbour {
  uint32_t id;
  int32_t squared_distance;
};

// The k best neighbours seen so far, sorted ascending; one query descriptor's result.
class KnnList {
 public:
  explicit KnnList(int k) : k_(k) { items_.reserve(k + 1); }
  // Inserts unless already present (trees overlap) or worse than the k-th.
  void Offer(uint32_t id, int32_t squared_distance);
  bool full() const { return static_cast<int>(items_.size()) >= k_; }
  int32_t worst() const { return items_.back().squared_distance; }
  const std::vector<Neighbour>& items() const { return items_; }
  void Clear() { items_.clear(); }

 private:
  int k_;
  std::vector<Neighbour> items_;
};

class KdForest {
 public:
  // Builds `trees` trees over `ids` of `store`. Deterministic for a given seed.
  KdForest(const DescriptorStore& store, std::vector<uint32_t> ids, int trees, int leaf_size,
           uint32_t seed);

  // Adds to `result` the neighbours of `query` found by visiting at most `checks` descriptors.
  void Search(const uint8_t* query, int checks, KnnList* result) const;

  // The indexed ids (in the first tree's order).
  std::vector<uint32_t> ids() const;
  uint32_t size() const { return size_; }
  size_t memory_bytes() const;

 private:
  // Only inner nodes are stored (issue 34: the forests are the biggest thing beside the
  // descriptors). A subtree of at most leaf_size ids is always a leaf, so it needs no node: the
  // search knows each subtree's range of the tree's permutation (the left child takes the first
  // `left` ids of its parent's range) and scans a range that small. Nodes are in preorder, so an
  // inner node's left child is the next node and only the right one needs an index. Where every
  // node, leaves included, took 8 bytes, only the inner ones do: half as many nodes, and the
  // trees, hence every search, are the same.
  struct Node {
    // A leaf of more than leaf_size ids: descriptors equal on every sampled dimension.
    static constexpr uint8_t kLeaf = 255;
    // `left` too large for 16 bits: the size is in Tree::wide_left (only the top few levels).
    static constexpr uint16_t kWideLeft = 0xFFFF;
    uint8_t dim;     // split dimension, or kLeaf
    uint8_t value;   // descriptors with value <= it go left
    uint16_t left;   // ids in the left subtree, or kWideLeft
    uint32_t right;  // the right child's node, when the right subtree is larger than a leaf
  };
  static_assert(sizeof(Node) == 8);
  // A tree's permutation of the ids (a subtree is a slice of it). Once built, it is held as
  // 3-byte offsets from the smallest id when the ids span fewer than 2^24 (every level of a
  // database of up to about 45,000 views): 12 instead of 16 bytes per descriptor for 4 trees.
  struct Tree {
    std::vector<Node> nodes;
    std::vector<std::pair<uint32_t, uint32_t>> wide_left;  // (node, left size), by node
    std::vector<uint32_t> ids;    // while building, or when the ids span too much to pack
    std::vector<uint8_t> packed;  // 3 bytes per id, little-endian, then one byte of padding
  };
  static constexpr uint32_t kNoNode = 0xFFFFFFFFu;
  uint32_t Id(const Tree& tree, uint32_t i) const {
    if (tree.packed.empty()) return tree.ids[i];
    uint32_t offset;
    std::memcpy(&offset, tree.packed.data() + 3 * static_cast<size_t>(i), sizeof offset);
    return base_ + (offset & 0xFFFFFFu);
  }
  static uint32_t LeftSize(const Tree& tree, uint32_t node);
  void Pack(Tree* tree) const;

  // Builds the subtree of ids [first, last); returns its node, or kNoNode for a leaf of at most
  // leaf_size ids.
  uint32_t BuildNode(Tree* tree, uint32_t first, uint32_t last, uint32_t* rng);

  const DescriptorStore& store_;
  int leaf_size_;
  uint32_t size_ = 0;
  uint32_t base_ = 0;  // the smallest id
  std::vector<Tree> trees_;
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_KD_FOREST_H_
