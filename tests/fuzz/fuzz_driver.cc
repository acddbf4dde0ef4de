// waymark-fuzz: runs the fuzz targets (fuzz_targets.h) without libFuzzer, with the project's own
// compiler: every seed (the target's own, then the files of corpus/<target>/), then --runs inputs
// mutated from them by a generator with a fixed seed (flips, random bytes, inserted, deleted and
// duplicated runs, truncation, splices of two seeds, "interesting" numbers written over bytes).
// The count of runs is fixed, not the time, so a loaded machine runs the same inputs, only slower.
//
//   waymark-fuzz --target NAME [--corpus DIR] [--runs N] [--seed S] [--max-memory-mb M]
//                [--answers FILE]
//   waymark-fuzz --list
//
// --answers FILE (the request targets; issue 35): every answer the services gave is written to
// FILE for a strict parser in another language (tests/fuzz/parse_answers.py, Python's protobuf):
// records of [u32 name length][message type name][u32 length][serialized message], little
// endian; a failed call's status message as a google.protobuf.StringValue (a proto3 string too);
// then FILE.fds, the FileDescriptorSet of every type written.
//
// A crash is a crash of this process (ctest reports it); the input that caused it is written to
// ./fuzz-crash-<target> first, so it can be replayed (--replay FILE) and kept in the corpus.
// Memory is a crash too: the process may map at most --max-memory-mb (2048) beyond what it had
// at start, so an input that makes a parser allocate gigabytes (a corrupt count) ends in
// std::bad_alloc and an abort, as libFuzzer's malloc limit ends `make fuzz`, instead of passing
// slowly on a machine with the memory to spare.

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/wrappers.pb.h>

#include <set>

#include "tests/fuzz/fuzz_targets.h"
#include "tests/fuzz/service_calls.h"

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

// The process's mapped size now (VmSize, /proc/self/statm's first field in pages).
size_t MappedBytes() {
  std::ifstream statm("/proc/self/statm");
  size_t pages = 0;
  statm >> pages;
  return pages * static_cast<size_t>(sysconf(_SC_PAGESIZE));
}

void LimitMemory(long extra_mb) {
  rlimit limit{};
  limit.rlim_cur = limit.rlim_max = MappedBytes() + (static_cast<size_t>(extra_mb) << 20);
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::perror("setrlimit(RLIMIT_AS)");
}

// ./fuzz-crash-<target>, holding the input being run: written before each run, so that whatever
// ends the process (a crash, an abort, ctest killing a hang) leaves the input there to replay.
// Overwritten in place rather than truncated to nothing and rewritten, which ext4 flushes to disk
// on every close (that cost more than most targets' own work).
class CrashFile {
 public:
  explicit CrashFile(const std::string& target)
      : path_("fuzz-crash-" + target), fd_(open(path_.c_str(), O_WRONLY | O_CREAT, 0644)) {
    if (fd_ < 0) std::perror(path_.c_str());
  }
  ~CrashFile() {
    if (fd_ >= 0) close(fd_);
  }
  void Keep(const std::string& input) {
    if (fd_ < 0) return;
    if (pwrite(fd_, input.data(), input.size(), 0) != static_cast<ssize_t>(input.size()) ||
        ftruncate(fd_, static_cast<off_t>(input.size())) != 0) {
      std::perror(path_.c_str());
    }
  }
  // After a run without a crash.
  void Remove() { fs::remove(path_); }

 private:
  std::string path_;
  int fd_;
};

// The answers of --answers, as the file comment says.
class AnswerFile {
 public:
  explicit AnswerFile(const std::string& path) : path_(path), out_(path, std::ios::binary) {
    if (!out_) std::perror(path.c_str());
  }
  ~AnswerFile() {
    google::protobuf::FileDescriptorSet set;
    for (const google::protobuf::FileDescriptor* file : files_) file->CopyTo(set.add_file());
    std::ofstream(path_ + ".fds", std::ios::binary) << set.SerializeAsString();
  }
  void Add(const google::protobuf::Message* response, const grpc::Status& status) {
    google::protobuf::StringValue message;
    if (response == nullptr) message.set_value(status.error_message());
    const google::protobuf::Message& answer = response != nullptr ? *response : message;
    // Serialized as it is, invalid UTF-8 included (protobuf's C++ only logs that), so that the
    // reader sees what a client would.
    Write(answer.GetDescriptor()->full_name());
    Write(answer.SerializeAsString());
    AddFile(answer.GetDescriptor()->file());
    ++count_;
  }
  size_t count() const { return count_; }

 private:
  void Write(const std::string& bytes) {
    const uint32_t n = static_cast<uint32_t>(bytes.size());
    const unsigned char length[4] = {static_cast<unsigned char>(n), static_cast<unsigned char>(n >> 8),
                                     static_cast<unsigned char>(n >> 16),
                                     static_cast<unsigned char>(n >> 24)};
    out_.write(reinterpret_cast<const char*>(length), 4);
    out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  // A file and what it imports, dependencies first (the order a pool is built in).
  void AddFile(const google::protobuf::FileDescriptor* file) {
    if (seen_.count(file)) return;
    seen_.insert(file);
    for (int i = 0; i < file->dependency_count(); ++i) AddFile(file->dependency(i));
    files_.push_back(file);
  }

  std::string path_;
  std::ofstream out_;
  std::set<const google::protobuf::FileDescriptor*> seen_;
  std::vector<const google::protobuf::FileDescriptor*> files_;
  size_t count_ = 0;
};

void Run(const FuzzTarget& target, CrashFile& crash_file, const std::string& input) {
  crash_file.Keep(input);
  target.run(reinterpret_cast<const uint8_t*>(input.data()), input.size());
}

}  // namespace

int main(int argc, char** argv) {
  std::string name, corpus, replay, answers;
  long runs = 10000;
  long max_memory_mb = 2048;
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
    else if (arg == "--max-memory-mb") max_memory_mb = std::stol(value());
    else if (arg == "--list") list = true;
    else if (arg == "--answers") answers = value();
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
  LimitMemory(max_memory_mb);
  std::unique_ptr<AnswerFile> answer_file;
  if (!answers.empty()) {
    answer_file = std::make_unique<AnswerFile>(answers);
    waymark::fuzz::Answers() = [&answer_file](const google::protobuf::Message* response,
                                              const grpc::Status& status) {
      answer_file->Add(response, status);
    };
  }
  if (!replay.empty()) {
    const std::string input = ReadFile(replay);
    target->run(reinterpret_cast<const uint8_t*>(input.data()), input.size());
    return 0;
  }
  CrashFile crash_file(target->name);
  std::vector<std::string> seeds = target->seeds();
  if (!corpus.empty() && fs::is_directory(corpus)) {
    for (const auto& entry : fs::directory_iterator(corpus)) {
      if (entry.is_regular_file()) seeds.push_back(ReadFile(entry.path()));
    }
  }
  for (const std::string& s : seeds) Run(*target, crash_file, s);
  std::mt19937_64 random(seed);
  for (long r = 0; r < runs; ++r) Run(*target, crash_file, Mutate(seeds, random));
  crash_file.Remove();
  std::printf("%s: %zu seeds and %ld mutated inputs, no crash\n", target->name, seeds.size(), runs);
  if (answer_file) {
    std::printf("%s: %zu answers written to %s\n", target->name, answer_file->count(),
                answers.c_str());
    waymark::fuzz::Answers() = nullptr;
    answer_file.reset();  // writes FILE.fds
  }
  return 0;
}
