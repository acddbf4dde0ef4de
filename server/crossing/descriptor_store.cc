#include "server/crossing/descriptor_store.h"

#include <algorithm>
#include <cstring>

namespace waymark::crossing {

uint32_t DescriptorStore::Append(const uint8_t* descriptors, uint32_t count, uint32_t view) {
  const uint32_t first = size_;
  for (uint32_t i = 0; i < count;) {
    const uint32_t id = size_;
    const uint32_t offset = id & (kBlockSize - 1);
    if (offset == 0) blocks_.emplace_back(new uint8_t[static_cast<size_t>(kBlockSize) * 128]);
    const uint32_t n = std::min(count - i, kBlockSize - offset);
    std::memcpy(blocks_.back().get() + static_cast<size_t>(offset) * 128,
                descriptors + static_cast<size_t>(i) * 128, static_cast<size_t>(n) * 128);
    size_ += n;
    i += n;
  }
  if (count > 0) {
    first_ids_.push_back(first);
    views_.push_back(view);
  }
  return first;
}

}  // namespace waymark::crossing
