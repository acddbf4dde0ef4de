#include "tests/support/server_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "absl/strings/str_cat.h"

namespace waymark::testing {
namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

std::string ServerBinary() {
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
  server->log_path_ = db_path + ".log." + std::to_string(std::rand());
  std::vector<std::string> argv = {binary, "--listen", listen, "--db", db_path};
  argv.insert(argv.end(), args.begin(), args.end());
  int broken_pipe[2] = {-1, -1};
  if (stderr_to == Stderr::kClosedPipe && pipe(broken_pipe) != 0) {
    return absl::InternalError("pipe failed");
  }
  const pid_t pid = fork();
  if (pid < 0) return absl::InternalError("fork failed");
  if (pid == 0) {
    const int fd = open(server->log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, STDOUT_FILENO);
    if (stderr_to == Stderr::kClosedPipe) {
      close(broken_pipe[0]);
      dup2(broken_pipe[1], STDERR_FILENO);
      close(broken_pipe[1]);
    } else {
      dup2(fd, STDERR_FILENO);
    }
    // The test's own disposition (gtest leaves SIGPIPE at its default) must not decide the
    // server's: it sets its own.
    signal(SIGPIPE, SIG_DFL);
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    execv(binary.c_str(), cargv.data());
    _exit(127);
  }
  if (stderr_to == Stderr::kClosedPipe) {
    close(broken_pipe[0]);  // the last read end: the server's stderr now leads nowhere
    close(broken_pipe[1]);
  }
  server->pid_ = pid;
  const std::string marker = "listening on ";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    const std::string log = ReadFile(server->log_path_);
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
      absl::StrCat("server did not report listening in 60 s:\n", ReadFile(server->log_path_)));
}

ServerProcess::~ServerProcess() {
  if (pid_ > 0 && Running()) Stop(SIGKILL);
}

bool ServerProcess::Running() {
  if (pid_ <= 0) return false;
  int status = 0;
  const pid_t r = waitpid(pid_, &status, WNOHANG);
  if (r == pid_) {
    pid_ = -1;
    return false;
  }
  return r == 0;
}

int ServerProcess::ExitCode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

int ServerProcess::Stop(int signal) {
  if (pid_ <= 0) return -1;
  kill(pid_, signal);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return ExitCode(status);
}

void ServerProcess::Signal(int signal) {
  if (pid_ > 0) kill(pid_, signal);
}

std::optional<int> ServerProcess::WaitForExit(absl::Duration timeout) {
  if (pid_ <= 0) return -1;
  const absl::Time deadline = absl::Now() + timeout;
  while (true) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return ExitCode(status);
    }
    if (absl::Now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string ServerProcess::Log() const { return ReadFile(log_path_); }

}  // namespace waymark::testing
