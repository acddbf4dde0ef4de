#include "tests/support/server_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "absl/strings/str_cat.h"

namespace waymark::testing {

std::string ServerBinary() {
  // A long bench can run a copy, so that rebuilding meanwhile does not replace it mid-run.
  if (const char* chosen = std::getenv("WAYMARK_SERVER_BINARY"); chosen != nullptr && *chosen) {
    return chosen;
  }
#ifdef WAYMARK_BINARY_DIR
  return std::string(WAYMARK_BINARY_DIR) + "/bin/waymark-server";
#else
  return "waymark-server";
#endif
}

CommandResult RunBinary(const std::string& binary, const std::string& args, bool merge_stderr) {
#ifdef WAYMARK_BINARY_DIR
  const std::string path = std::string(WAYMARK_BINARY_DIR) + "/bin/" + binary;
#else
  const std::string path = binary;
#endif
  const std::string command = path + " " + args + (merge_stderr ? " 2>&1" : "");
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.output.append(buffer, n);
  const int status = pclose(pipe);
  result.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string MakeTempDir(const std::string& prefix) {
  std::string pattern = "/tmp/" + prefix + "-XXXXXX";
  char* dir = mkdtemp(pattern.data());
  return dir == nullptr ? std::string("/tmp") : std::string(dir);
}

absl::StatusOr<std::unique_ptr<ServerProcess>> ServerProcess::Start(
    const std::string& binary, const std::string& db_path, const std::vector<std::string>& args,
    const std::string& listen, Stderr stderr_to) {
  std::vector<std::string> insecure = {"--insecure-dev"};
  insecure.insert(insecure.end(), args.begin(), args.end());
  return StartWithAuth(binary, db_path, insecure, listen, stderr_to);
}

absl::StatusOr<std::unique_ptr<ServerProcess>> ServerProcess::StartWithAuth(
    const std::string& binary, const std::string& db_path, const std::vector<std::string>& args,
    const std::string& listen, Stderr stderr_to) {
  std::unique_ptr<ServerProcess> server(new ServerProcess());
  // Beside a database file; a PostgreSQL URI is no place for a log.
  const bool uri = db_path.rfind("postgresql://", 0) == 0 || db_path.rfind("postgres://", 0) == 0;
  const std::string log_base = uri ? MakeTempDir("waymark-server-log") + "/server" : db_path;
  // A name no earlier server of any process used, and no file there yet: the child truncates it
  // only once it runs, and a stale "listening on" line read before that named a dead server (a
  // benchmark's second run in the same folder: std::rand() repeats across processes).
  static std::atomic<int> started{0};
  server->log_path_ = absl::StrCat(log_base, ".log.", getpid(), ".", started++);
  std::remove(server->log_path_.c_str());
  ChildProcess::Options options;
  options.argv = {binary, "--listen", listen, "--db", db_path};
  options.argv.insert(options.argv.end(), args.begin(), args.end());
  options.stdout_path = options.stderr_path = server->log_path_;
  options.stderr_to_closed_pipe = stderr_to == Stderr::kClosedPipe;
  absl::StatusOr<std::unique_ptr<ChildProcess>> process = ChildProcess::Start(options);
  if (!process.ok()) return process.status();
  server->process_ = *std::move(process);
  const std::string marker = "listening on ";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    const std::string log = ReadWholeFile(server->log_path_);
    const size_t at = log.find(marker);
    if (at != std::string::npos) {
      const size_t end = log.find('\n', at);
      if (end != std::string::npos) {
        server->address_ = log.substr(at + marker.size(), end - at - marker.size());
        return server;
      }
    }
    if (!server->Running()) {
      return absl::InternalError(absl::StrCat("server exited before listening:\n", log));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return absl::DeadlineExceededError(
      absl::StrCat("server did not report listening in 60 s:\n", ReadWholeFile(server->log_path_)));
}

ServerProcess::~ServerProcess() = default;  // the child process kills a server still running

bool ServerProcess::Running() { return process_->Running(); }

int ServerProcess::Stop(int signal) { return process_->Stop(signal); }

void ServerProcess::Signal(int signal) { process_->Signal(signal); }

std::optional<int> ServerProcess::WaitForExit(absl::Duration timeout) {
  return process_->WaitFor(timeout);
}

std::string ServerProcess::Log() const { return ReadWholeFile(log_path_); }

}  // namespace waymark::testing
