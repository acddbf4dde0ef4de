// MemoryTrimmer gives back heap that was freed but that the allocator kept: 100 MB of small
// blocks freed below one block still in use (so the heap's top cannot shrink) stay resident
// until the trimmer's check, which returns them.
#include "server/service/runtime/memory_trimmer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <thread>
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

// What the server asks when a SLAM session leaves memory (issue 38): the heap just freed goes
// back although the process did not grow (the growth check alone never trimmed after a close).
// 100 MB of small blocks freed below a pinned one, as above.
struct FreedHeap {
  FreedHeap() {
    std::vector<char*> blocks;
    for (int i = 0; i < 200000; ++i) {
      char* block = static_cast<char*>(std::malloc(512));
      std::memset(block, 1, 512);
      blocks.push_back(block);
    }
    pin = static_cast<char*>(std::malloc(512));
    std::memset(pin, 1, 512);
    for (char* block : blocks) std::free(block);
  }
  ~FreedHeap() { std::free(pin); }
  char* pin = nullptr;
};

TEST(MemoryTrimmerTest, TrimSoonReturnsFreedHeapWithoutAGrowth) {
  MemoryTrimmerOptions options;
  options.period_seconds = 0;  // no thread: TrimSoon trims at once
  options.growth_mb = 1e6;     // the growth check never trims here
  MemoryTrimmer trimmer(options);
  FreedHeap heap;
  const double freed = ResidentMegabytes();
  trimmer.CheckOnce();  // the baseline: no trim
  EXPECT_EQ(trimmer.trims(), 0);
  trimmer.TrimSoon();
  EXPECT_EQ(trimmer.trims(), 1);
  EXPECT_LT(ResidentMegabytes(), freed - 64);
}

TEST(MemoryTrimmerTest, TheThreadServesTrimSoonRequests) {
  MemoryTrimmerOptions options;
  options.period_seconds = 3600;  // the periodic check never comes during the test
  options.growth_mb = 1e6;
  options.settle_seconds = 0.01;
  MemoryTrimmer trimmer(options);
  FreedHeap heap;
  const double freed = ResidentMegabytes();
  trimmer.TrimSoon();
  trimmer.TrimSoon();  // joins the first request or asks for a second trim: never lost
  // Waits for the thread (not a timing assertion: a generous bound on a loaded machine).
  for (int i = 0; i < 3000 && trimmer.trims() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_GE(trimmer.trims(), 1);
  EXPECT_LE(trimmer.trims(), 2);
  EXPECT_LT(ResidentMegabytes(), freed - 64);
}

}  // namespace
}  // namespace waymark::service
