#ifndef WAYMARK_SERVER_CROSSING_DESCRIPTOR_STORE_H_
#define WAYMARK_SERVER_CROSSING_DESCRIPTOR_STORE_H_

// Append-only storage of 128-byte descriptors, each labelled with the view it belongs to. The
// descriptors are the bulk of a crossing database's memory, so they are held once, as uint8, in
// fixed-size blocks: appending never moves what is already stored, so index levels built over a
// prefix stay valid while new views arrive.

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

namespace waymark::crossing {

class DescriptorStore {
 public:
  static constexpr int kBlockShift = 14;  // 16384 descriptors (2 MiB) per block
  static constexpr uint32_t kBlockSize = 1u << kBlockShift;

  // Appends `count` descriptors (count * 128 bytes) labelled `view`; returns the first id.
  uint32_t Append(const uint8_t* descriptors, uint32_t count, uint32_t view);

  const uint8_t* Get(uint32_t id) const {
    return blocks_[id >> kBlockShift].get() + static_cast<size_t>(id & (kBlockSize - 1)) * 128;
  }
  // The view of descriptor `id` (ids past the end: the last view appended). A binary search over
  // the appends, one entry per view, where a label per descriptor cost 4 bytes each (issue 34).
  uint32_t ViewOf(uint32_t id) const {
    const auto after = std::upper_bound(first_ids_.begin(), first_ids_.end(), id);
    return after == first_ids_.begin() ? 0 : views_[after - first_ids_.begin() - 1];
  }
  uint32_t size() const { return size_; }
  // Bytes of the view labels (ViewOf).
  size_t label_bytes() const {
    return (first_ids_.capacity() + views_.capacity()) * sizeof(uint32_t);
  }
  // Bytes of descriptor data held (allocated blocks).
  size_t descriptor_bytes() const { return blocks_.size() * static_cast<size_t>(kBlockSize) * 128; }

 private:
  std::vector<std::unique_ptr<uint8_t[]>> blocks_;
  // Per Append with descriptors, in order: the first id it stored and its view.
  std::vector<uint32_t> first_ids_;
  std::vector<uint32_t> views_;
  uint32_t size_ = 0;
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_DESCRIPTOR_STORE_H_
