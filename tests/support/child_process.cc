#include "tests/support/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace waymark::testing {

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool WaitUntil(const std::function<bool()>& condition, absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (absl::Now() < deadline) {
    if (condition()) return true;
    absl::SleepFor(absl::Milliseconds(20));
  }
  return condition();
}

absl::StatusOr<std::unique_ptr<ChildProcess>> ChildProcess::Start(const Options& options) {
  if (options.argv.empty()) return absl::InvalidArgumentError("no program to run");
  std::unique_ptr<ChildProcess> child(new ChildProcess());
  child->stdout_path_ = options.stdout_path;
  child->stderr_path_ = options.stderr_path;
  int pipe_fds[2] = {-1, -1};
  if (options.stdin_pipe) {
    if (pipe(pipe_fds) != 0) {
      return absl::InternalError(absl::StrCat("pipe: ", std::strerror(errno)));
    }
    // A write to a child that has exited must fail with EPIPE, not kill the test.
    signal(SIGPIPE, SIG_IGN);
  }
  // Everything the child needs is prepared before fork: after it, only async-signal-safe calls.
  std::vector<std::string> argv = options.argv;
  std::vector<char*> cargv;
  for (std::string& a : argv) cargv.push_back(a.data());
  cargv.push_back(nullptr);
  const bool one_log = options.stdout_path == options.stderr_path;
  int broken_pipe[2] = {-1, -1};
  if (options.stderr_to_closed_pipe && pipe(broken_pipe) != 0) {
    return absl::InternalError(absl::StrCat("pipe: ", std::strerror(errno)));
  }
  const pid_t pid = fork();
  if (pid < 0) return absl::InternalError(absl::StrCat("fork: ", std::strerror(errno)));
  if (pid == 0) {
    const int in = options.stdin_pipe ? pipe_fds[0] : open("/dev/null", O_RDONLY);
    const int out = open(options.stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = options.stderr_to_closed_pipe ? broken_pipe[1]
                    : one_log ? out
                              : open(options.stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || out < 0 || err < 0) _exit(126);
    dup2(in, STDIN_FILENO);
    dup2(out, STDOUT_FILENO);
    dup2(err, STDERR_FILENO);
    if (options.stdin_pipe) close(pipe_fds[1]);  // else the child never sees end of input
    if (options.stderr_to_closed_pipe) close(broken_pipe[0]);
    signal(SIGPIPE, SIG_DFL);  // an ignored signal would stay ignored across exec
    execv(cargv[0], cargv.data());
    _exit(127);
  }
  child->pid_ = pid;
  if (options.stderr_to_closed_pipe) {
    close(broken_pipe[0]);  // the last read end: the child's stderr now leads nowhere
    close(broken_pipe[1]);
  }
  if (options.stdin_pipe) {
    close(pipe_fds[0]);
    child->stdin_fd_ = pipe_fds[1];
  }
  return child;
}

ChildProcess::~ChildProcess() {
  CloseStdin();
  if (Running()) Stop(SIGKILL);
}

absl::Status ChildProcess::WriteStdin(absl::string_view bytes) {
  if (stdin_fd_ < 0) return absl::FailedPreconditionError("the child has no stdin pipe (any more)");
  while (!bytes.empty()) {
    const ssize_t n = write(stdin_fd_, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return absl::UnavailableError(absl::StrCat("write: ", std::strerror(errno)));
    bytes.remove_prefix(static_cast<size_t>(n));
  }
  return absl::OkStatus();
}

void ChildProcess::CloseStdin() {
  if (stdin_fd_ >= 0) close(stdin_fd_);
  stdin_fd_ = -1;
}

int ChildProcess::Reap(int options) {
  if (pid_ <= 0) return exit_code_;
  int status = 0;
  if (waitpid(pid_, &status, options) != pid_) return -1;
  pid_ = -1;
  if (WIFEXITED(status)) exit_code_ = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) exit_code_ = 128 + WTERMSIG(status);
  return exit_code_;
}

bool ChildProcess::Running() {
  if (pid_ <= 0) return false;
  Reap(WNOHANG);
  return pid_ > 0;
}

int ChildProcess::Stop(int signal) {
  if (pid_ > 0) kill(pid_, signal);
  return Wait();
}

int ChildProcess::Wait() { return pid_ > 0 ? Reap(0) : exit_code_; }

void ChildProcess::Signal(int signal) {
  if (pid_ > 0) kill(pid_, signal);
}

std::optional<int> ChildProcess::WaitFor(absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (Running()) {
    if (absl::Now() >= deadline) return std::nullopt;
    absl::SleepFor(absl::Milliseconds(50));
  }
  return exit_code_;
}

std::string ChildProcess::Stdout() const { return ReadWholeFile(stdout_path_); }
std::string ChildProcess::Stderr() const { return ReadWholeFile(stderr_path_); }

}  // namespace waymark::testing
