// waymark-fuzz as a libFuzzer binary (`make fuzz`: clang, AddressSanitizer and
// UndefinedBehaviorSanitizer, coverage-guided): the same targets as fuzz_driver.cc, one per
// process, named by an environment variable because libFuzzer owns the command line.
//
//   WAYMARK_FUZZ_TARGET=laser_checkpoint WAYMARK_FUZZ_SEEDS=work/laser_checkpoint \
//     waymark-fuzz -max_total_time=30 work/laser_checkpoint tests/fuzz/corpus/laser_checkpoint
//   WAYMARK_FUZZ_TARGET=list waymark-fuzz      prints the targets' names
//
// The target's own seeds (made by code from valid inputs) are written into WAYMARK_FUZZ_SEEDS, when
// set, before libFuzzer reads its corpus directories: naming that directory first makes the run
// start from them and keep what it finds there (libFuzzer writes new inputs to the first one).

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/fuzz/fuzz_targets.h"

namespace {

const waymark::fuzz::FuzzTarget* g_target = nullptr;

void WriteSeeds(const waymark::fuzz::FuzzTarget& target, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  int index = 0;
  for (const std::string& seed : target.seeds()) {
    std::ofstream(dir / ("seed-" + std::to_string(index++)), std::ios::binary) << seed;
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* name = std::getenv("WAYMARK_FUZZ_TARGET");
  const std::string wanted = name != nullptr ? name : "";
  for (const waymark::fuzz::FuzzTarget& t : waymark::fuzz::Targets()) {
    if (wanted == "list") std::printf("%s\n", t.name);
    if (wanted == t.name) g_target = &t;
  }
  if (wanted == "list") std::exit(0);
  if (g_target == nullptr) {
    std::fprintf(stderr, "WAYMARK_FUZZ_TARGET='%s' names no target (WAYMARK_FUZZ_TARGET=list)\n",
                 wanted.c_str());
    std::exit(2);
  }
  if (const char* seeds = std::getenv("WAYMARK_FUZZ_SEEDS")) WriteSeeds(*g_target, seeds);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  g_target->run(data, size);
  return 0;
}
