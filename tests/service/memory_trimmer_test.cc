// MemoryTrimmer gives back heap that was freed but that the allocator kept: 100 MB of small
// blocks freed below one block still in use (so the heap's top cannot shrink) stay resident
// until the trimmer's check, which returns them.
#include "server/service/runtime/memory_trimmer.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <vector>

#include "server/common/process_memory.h"

namespace waymark::service {
namespace {

TEST(MemoryTrimmerTest, ReturnsFreedHeapAfterAGrowthAndLeavesSmallChangesAlone) {
  MemoryTrimmerOptions options;
  options.period_seconds = 0;  // no thread: checks only when asked
  options.growth_mb = 32;
  MemoryTrimmer trimmer(options);
  const double start = trimmer.CheckOnce();
  ASSERT_GT(start, 0);

  std::vector<char*> blocks;
  for (int i = 0; i < 200000; ++i) {  // 200000 x 512 B: about 100 MB, from the heap (not mmap)
    char* block = static_cast<char*>(std::malloc(512));
    std::memset(block, 1, 512);
    blocks.push_back(block);
  }
  char* pin = static_cast<char*>(std::malloc(512));  // above them all: the top stays in use
  std::memset(pin, 1, 512);
  for (char* block : blocks) std::free(block);
  const double freed = ResidentMegabytes();
  EXPECT_GT(freed, start + 64) << "the allocator kept the freed blocks resident";

  const double after = trimmer.CheckOnce();
  EXPECT_LT(after, freed - 64);
  EXPECT_EQ(trimmer.trims(), 1);
  // A change below growth_mb is left alone.
  trimmer.CheckOnce();
  EXPECT_EQ(trimmer.trims(), 1);
  std::free(pin);
}

}  // namespace
}  // namespace waymark::service
