// waymark-fuzz: runs the fuzz targets (fuzz_targets.h) without libFuzzer, with the project's own
// compiler: every seed (the target's own, then the files of corpus/<target>/), then --runs inputs
// mutated from them by a generator with a fixed seed (flips, random bytes, inserted, deleted and
// duplicated runs, truncation, splices of two seeds, "interesting" numbers written over bytes).
// The count of runs is fixed, not the time, so a loaded machine runs the same inputs, only slower.
//
//   waymark-fuzz --target NAME [--corpus DIR] [--runs N] [--seed S]
//   waymark-fuzz --list
//
// A crash is a crash of this process (ctest reports it); the input that caused it is written to
// ./fuzz-crash-<target> first, so it can be replayed (--replay FILE) and kept in the corpus.

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "tests/fuzz/fuzz_targets.h"

namespace {

namespace fs = std::filesystem;
using waymark::fuzz::FuzzTarget;

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string Mutate(const std::vector<std::string>& seeds, std::mt19937_64& random) {
  auto pick = [&](size_t n) { return n == 0 ? 0 : static_cast<size_t>(random() % n); };
  std::string input = seeds[pick(seeds.size())];
  const int steps = 1 + static_cast<int>(pick(4));
  for (int s = 0; s < steps; ++s) {
    switch (pick(8)) {
      case 0:  // flip a bit
        if (!input.empty()) input[pick(input.size())] ^= static_cast<char>(1 << pick(8));
        break;
      case 1:  // a random byte
        if (!input.empty()) input[pick(input.size())] = static_cast<char>(random());
        break;
      case 2: {  // insert random bytes
        std::string bytes(1 + pick(16), '\0');
        for (char& b : bytes) b = static_cast<char>(random());
        input.insert(pick(input.size() + 1), bytes);
        break;
      }
      case 3:  // delete a run
        if (!input.empty()) {
          const size_t at = pick(input.size());
          input.erase(at, 1 + pick(std::min<size_t>(64, input.size() - at)));
        }
        break;
      case 4:  // duplicate a run
        if (!input.empty()) {
          const size_t at = pick(input.size());
          input.insert(pick(input.size() + 1), input.substr(at, 1 + pick(32)));
        }
        break;
      case 5:  // truncate
        input.resize(pick(input.size() + 1));
        break;
      case 6: {  // splice with another seed
        const std::string& other = seeds[pick(seeds.size())];
        input = input.substr(0, pick(input.size() + 1)) + other.substr(pick(other.size() + 1));
        break;
      }
      default: {  // an interesting number over some bytes (lengths, counts, NaN, huge values)
        static const uint64_t kInteresting[] = {0,          1,          0x7f,       0xff,
                                                0xffff,     0x7fffffff, 0xffffffff, ~0ull,
                                                0x7ff8000000000000ull /* NaN */,
                                                0x7ff0000000000000ull /* inf */,
                                                0x7fefffffffffffffull /* max double */};
        const uint64_t value = kInteresting[pick(std::size(kInteresting))];
        const size_t width = size_t{1} << pick(4);  // 1, 2, 4 or 8 bytes
        if (input.size() >= width) {
          std::memcpy(&input[pick(input.size() - width + 1)], &value, width);
        }
        break;
      }
    }
  }
  return input;
}

void Run(const FuzzTarget& target, const std::string& input) {
  // Written before the run: if the target crashes, the input is there to replay.
  {
    std::ofstream(std::string("fuzz-crash-") + target.name, std::ios::binary) << input;
  }
  target.run(reinterpret_cast<const uint8_t*>(input.data()), input.size());
}

}  // namespace

int main(int argc, char** argv) {
  std::string name, corpus, replay;
  long runs = 10000;
  unsigned long long seed = 1;
  bool list = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (arg == "--target") name = value();
    else if (arg == "--corpus") corpus = value();
    else if (arg == "--runs") runs = std::stol(value());
    else if (arg == "--seed") seed = std::stoull(value());
    else if (arg == "--replay") replay = value();
    else if (arg == "--list") list = true;
    else {
      std::fprintf(stderr, "unknown argument %s\n", arg.c_str());
      return 2;
    }
  }
  if (list) {
    for (const FuzzTarget& t : waymark::fuzz::Targets()) std::printf("%s\n", t.name);
    return 0;
  }
  const FuzzTarget* target = nullptr;
  for (const FuzzTarget& t : waymark::fuzz::Targets()) {
    if (name == t.name) target = &t;
  }
  if (target == nullptr) {
    std::fprintf(stderr, "no target '%s' (--list names them)\n", name.c_str());
    return 2;
  }
  if (!replay.empty()) {
    Run(*target, ReadFile(replay));
    return 0;
  }
  std::vector<std::string> seeds = target->seeds();
  if (!corpus.empty() && fs::is_directory(corpus)) {
    for (const auto& entry : fs::directory_iterator(corpus)) {
      if (entry.is_regular_file()) seeds.push_back(ReadFile(entry.path()));
    }
  }
  for (const std::string& s : seeds) Run(*target, s);
  std::mt19937_64 random(seed);
  for (long r = 0; r < runs; ++r) Run(*target, Mutate(seeds, random));
  fs::remove(std::string("fuzz-crash-") + target->name);
  std::printf("%s: %zu seeds and %ld mutated inputs, no crash\n", target->name, seeds.size(), runs);
  return 0;
}
