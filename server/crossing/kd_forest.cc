#include "server/crossing/kd_forest.h"

#include <algorithm>
#include <array>
#include <limits>
#include <numeric>
#include <utility>
#include <queue>

#include "server/crossing/l2_distance.h"

namespace waymark::crossing {
namespace {

// Split dimension: one of the few highest-variance dimensions, chosen at random, so that the
// trees differ (the "randomized" in randomized k-d trees; FLANN uses the top 5).
constexpr int kRandomDims = 5;
// Variance is estimated on at most this many descriptors of the node.
constexpr uint32_t kVarianceSample = 100;

uint32_t NextRandom(uint32_t* state) {  // xorshift32: small, fast, deterministic
  uint32_t x = *state;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  return *state = x;
}

struct Branch {
  int32_t bound;  // squared distance from the query to the splitting plane
  uint16_t tree;
  uint32_t node;  // the subtree's node (unused when it is a leaf)
  uint32_t first, last;  // its range of the tree's permutation
  bool operator>(const Branch& other) const { return bound > other.bound; }
};

}  // namespace

void KnnList::Offer(uint32_t id, int32_t squared_distance) {
  if (full() && squared_distance >= worst()) return;
  for (const Neighbour& n : items_) {
    if (n.id == id) return;
  }
  auto it = std::upper_bound(
      items_.begin(), items_.end(), squared_distance,
      [](int32_t d, const Neighbour& n) { return d < n.squared_distance; });
  items_.insert(it, Neighbour{id, squared_distance});
  if (static_cast<int>(items_.size()) > k_) items_.pop_back();
}

KdForest::KdForest(const DescriptorStore& store, std::vector<uint32_t> ids, int trees,
                   int leaf_size, uint32_t seed)
    : store_(store), leaf_size_(std::max(1, leaf_size)) {
  trees_.resize(std::max(1, trees));
  uint32_t rng = seed * 2654435761u + 1;
  const uint32_t n = static_cast<uint32_t>(ids.size());
  size_ = n;
  if (n > 0) base_ = *std::min_element(ids.begin(), ids.end());
  for (size_t t = 0; t < trees_.size(); ++t) {
    Tree& tree = trees_[t];
    tree.ids = t + 1 < trees_.size() ? ids : std::move(ids);
    tree.nodes.reserve(n / leaf_size_ + 1);
    BuildNode(&tree, 0, n, &rng);
    Pack(&tree);
    // Leaves hold fewer than leaf_size on average, so the reserve was short and the vector had
    // doubled: give back what the tree does not use.
    tree.nodes.shrink_to_fit();
    tree.wide_left.shrink_to_fit();
  }
}

void KdForest::Pack(Tree* tree) const {
  if (tree->ids.empty()) return;
  const uint32_t top = *std::max_element(tree->ids.begin(), tree->ids.end());
  if (top - base_ >= (1u << 24)) return;  // kept as 4-byte ids
  tree->packed.resize(3 * tree->ids.size() + 1);
  for (size_t i = 0; i < tree->ids.size(); ++i) {
    const uint32_t offset = tree->ids[i] - base_;
    tree->packed[3 * i] = static_cast<uint8_t>(offset);
    tree->packed[3 * i + 1] = static_cast<uint8_t>(offset >> 8);
    tree->packed[3 * i + 2] = static_cast<uint8_t>(offset >> 16);
  }
  std::vector<uint32_t>().swap(tree->ids);  // (= {} would keep the capacity)
}

std::vector<uint32_t> KdForest::ids() const {
  std::vector<uint32_t> out(size_);
  for (uint32_t i = 0; i < size_; ++i) out[i] = Id(trees_.front(), i);
  return out;
}

uint32_t KdForest::LeftSize(const Tree& tree, uint32_t node) {
  const Node& n = tree.nodes[node];
  if (n.left != Node::kWideLeft) return n.left;
  const auto it = std::lower_bound(
      tree.wide_left.begin(), tree.wide_left.end(), node,
      [](const std::pair<uint32_t, uint32_t>& entry, uint32_t key) { return entry.first < key; });
  return it->second;
}

uint32_t KdForest::BuildNode(Tree* tree, uint32_t first, uint32_t last, uint32_t* rng) {
  if (last - first <= static_cast<uint32_t>(leaf_size_)) return kNoNode;
  const uint32_t index = static_cast<uint32_t>(tree->nodes.size());
  // A leaf of equal descriptors stays one up to this size (what the first layout's 16-bit leaf
  // count could say; kept so that the trees stay the same).
  constexpr uint32_t kMaxLeaf = std::numeric_limits<uint16_t>::max();
  tree->nodes.push_back(Node{Node::kLeaf, 0, 0, 0});

  // Mean and variance per dimension over a sample of the node's descriptors, in integers: sums
  // and sums of squares (at most a few hundred samples of 255^2 fit in 32 bits) vectorise, and
  // n * sum(d^2) - sum(d)^2 = n^2 * variance is exact, so the ranking of the dimensions is too.
  // (This was the top of an enrollment's profile: trees are rebuilt as levels merge.)
  std::array<int32_t, 128> sum{}, sum_sq{};
  const uint32_t count = last - first;
  const uint32_t step = std::max<uint32_t>(1, count / kVarianceSample);
  int sampled = 0;
  for (uint32_t i = first; i < last; i += step, ++sampled) {
    const uint8_t* d = store_.Get(tree->ids[i]);
    for (int k = 0; k < 128; ++k) {
      sum[k] += d[k];
      sum_sq[k] += int32_t(d[k]) * d[k];
    }
  }
  std::array<int64_t, 128> spread;  // sampled^2 x variance
  for (int k = 0; k < 128; ++k) {
    spread[k] = int64_t(sampled) * sum_sq[k] - int64_t(sum[k]) * sum[k];
  }
  std::array<int, 128> dims;
  std::iota(dims.begin(), dims.end(), 0);
  std::partial_sort(dims.begin(), dims.begin() + kRandomDims, dims.end(),
                    [&](int a, int b) { return spread[a] > spread[b]; });
  const int dim = dims[NextRandom(rng) % kRandomDims];
  // All sampled descriptors equal: keep them as one leaf (split by position below when they are
  // more than a leaf's count can say).
  if (spread[dim] <= 0 && count <= kMaxLeaf) return index;

  // Split at the mean; descriptors with value <= split go left.
  const double mean = static_cast<double>(sum[dim]) / sampled;
  const uint8_t split = static_cast<uint8_t>(std::min(254.0, mean));
  auto middle = std::partition(tree->ids.begin() + first, tree->ids.begin() + last,
                               [&](uint32_t id) { return store_.Get(id)[dim] <= split; });
  uint32_t mid = static_cast<uint32_t>(middle - tree->ids.begin());
  if (mid == first || mid == last) mid = first + count / 2;  // degenerate: split by position

  Node& node = tree->nodes[index];
  node.dim = static_cast<uint8_t>(dim);
  node.value = split;
  if (mid - first < Node::kWideLeft) {
    node.left = static_cast<uint16_t>(mid - first);
  } else {
    node.left = Node::kWideLeft;
    tree->wide_left.emplace_back(index, mid - first);  // in preorder: sorted by node
  }
  BuildNode(tree, first, mid, rng);  // the left child: node index + 1
  const uint32_t right = BuildNode(tree, mid, last, rng);
  tree->nodes[index].right = right;  // (the children may have moved the vector)
  return index;
}

void KdForest::Search(const uint8_t* query, int checks, KnnList* result) const {
  if (size() == 0) return;
  std::priority_queue<Branch, std::vector<Branch>, std::greater<Branch>> branches;
  int checked = 0;
  // Descends from the subtree (`node`, ids [first, last)) to a leaf, queueing the far side of
  // every split on the way.
  auto descend = [&](uint16_t t, uint32_t node, uint32_t first, uint32_t last) {
    const Tree& tree = trees_[t];
    while (last - first > static_cast<uint32_t>(leaf_size_) &&
           tree.nodes[node].dim != Node::kLeaf) {
      const Node& n = tree.nodes[node];
      const uint32_t mid = first + LeftSize(tree, node);
      const int diff = static_cast<int>(query[n.dim]) - static_cast<int>(n.value);
      const bool go_left = diff <= 0;
      const int32_t bound = go_left ? (diff - 1) * (diff - 1) : diff * diff;
      if (!result->full() || bound < result->worst()) {
        branches.push(go_left ? Branch{bound, t, n.right, mid, last}
                              : Branch{bound, t, node + 1, first, mid});
      }
      if (go_left) {
        last = mid;
        ++node;
      } else {
        first = mid;
        node = n.right;
      }
    }
    for (uint32_t i = first; i < last; ++i) {
      const uint32_t id = Id(tree, i);
      result->Offer(id, SquaredL2(query, store_.Get(id)));
      ++checked;
    }
  };
  for (uint16_t t = 0; t < trees_.size(); ++t) descend(t, 0, 0, size_);
  while (!branches.empty() && checked < checks) {
    const Branch b = branches.top();
    branches.pop();
    if (result->full() && b.bound >= result->worst()) break;
    descend(b.tree, b.node, b.first, b.last);
  }
}

size_t KdForest::memory_bytes() const {
  size_t bytes = 0;
  for (const Tree& t : trees_) {
    bytes += t.nodes.capacity() * sizeof(Node) +
             t.wide_left.capacity() * sizeof(std::pair<uint32_t, uint32_t>) +
             t.ids.capacity() * sizeof(uint32_t) + t.packed.capacity();
  }
  return bytes;
}

}  // namespace waymark::crossing
