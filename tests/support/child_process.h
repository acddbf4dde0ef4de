#ifndef WAYMARK_TESTS_SUPPORT_CHILD_PROCESS_H_
#define WAYMARK_TESTS_SUPPORT_CHILD_PROCESS_H_

// A program run by a test: its stdout and stderr go to files the test reads while it runs, its
// stdin is an optional pipe the test writes (a teleop keyboard), and the test ends it with a
// signal once what it waited for has happened. Tests wait for events in the output, never for
// an amount of wall-clock time, so they pass on a loaded machine too.

#include <sys/types.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace waymark::testing {

class ChildProcess {
 public:
  struct Options {
    std::vector<std::string> argv;  // argv[0] is the program's path
    std::string stdout_path;        // created or truncated
    std::string stderr_path;        // may equal stdout_path (one log)
    bool stdin_pipe = false;        // else stdin is /dev/null
    // stderr is a pipe whose read end is closed (stderr_path unused): the child's first write to
    // it raises SIGPIPE, as for a program whose log went into a `tee` that was stopped.
    bool stderr_to_closed_pipe = false;
  };

  static absl::StatusOr<std::unique_ptr<ChildProcess>> Start(const Options& options);
  ~ChildProcess();  // kills a child that still runs
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  // Writes to the child's stdin (the pipe); FAILED_PRECONDITION without one or once closed.
  absl::Status WriteStdin(absl::string_view bytes);
  // End of input for the child.
  void CloseStdin();
  // True while the child runs.
  bool Running();
  // Sends `signal` (if it still runs) and waits for the exit: the exit code, or 128 + signal if
  // a signal ended it.
  int Stop(int signal);
  // Waits for the exit without a signal.
  int Wait();
  // Sends `signal` and returns at once.
  void Signal(int signal);
  // Waits up to `timeout` for the exit: its code as Stop() returns it, or nullopt.
  std::optional<int> WaitFor(absl::Duration timeout);

  std::string Stdout() const;
  std::string Stderr() const;

 private:
  ChildProcess() = default;
  int Reap(int options);  // waitpid; the exit code once reaped, else -1

  pid_t pid_ = -1;
  int exit_code_ = -1;
  int stdin_fd_ = -1;
  std::string stdout_path_;
  std::string stderr_path_;
};

// Polls `condition` every 20 ms until it holds or `timeout` passes; returns whether it held. The
// timeout is a bound for a broken build to fail rather than hang, not a speed requirement: pass a
// generous one.
bool WaitUntil(const std::function<bool()>& condition, absl::Duration timeout);

// The whole file ("" if it cannot be read).
std::string ReadWholeFile(const std::string& path);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_CHILD_PROCESS_H_
