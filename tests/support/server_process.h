#ifndef WAYMARK_TESTS_SUPPORT_SERVER_PROCESS_H_
#define WAYMARK_TESTS_SUPPORT_SERVER_PROCESS_H_

// Runs the real waymark-server binary for integration tests: on port 0, with its own database
// file, output captured to a log file that failing tests print.

#include <sys/types.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "tests/support/child_process.h"
#include "absl/time/time.h"

namespace waymark::testing {

class ServerProcess {
 public:
  // Where the server's stderr goes.
  enum class Stderr {
    kLog,         // the log file, with stdout
    kClosedPipe,  // a pipe whose read end is closed: every write is EPIPE (or SIGPIPE)
  };

  // Starts `binary --listen 127.0.0.1:0 --db db_path --insecure-dev args...` and waits (up to
  // 60 s) for its "listening on" line. Authentication is off (--insecure-dev): tests of
  // everything but auth call without tokens.
  // `listen` replaces 127.0.0.1:0, e.g. to restart a server on the port it had.
  static absl::StatusOr<std::unique_ptr<ServerProcess>> Start(const std::string& binary,
                                                              const std::string& db_path,
                                                              const std::vector<std::string>& args = {},
                                                              const std::string& listen = "127.0.0.1:0",
                                                              Stderr stderr_to = Stderr::kLog);
  // The same with authentication on (no --insecure-dev), as deployed: calls need tokens.
  static absl::StatusOr<std::unique_ptr<ServerProcess>> StartWithAuth(
      const std::string& binary, const std::string& db_path,
      const std::vector<std::string>& args = {}, const std::string& listen = "127.0.0.1:0",
      Stderr stderr_to = Stderr::kLog);
  ~ServerProcess();

  const std::string& address() const { return address_; }
  pid_t pid() const { return process_->pid(); }
  // Sends `signal` and waits for the exit; returns the exit code (128 + signal if killed).
  int Stop(int signal);
  // Sends `signal` and returns at once (see WaitForExit).
  void Signal(int signal);
  // Waits up to `timeout` for the process to exit: its exit code as Stop() returns it, or nullopt
  // while it still runs.
  std::optional<int> WaitForExit(absl::Duration timeout);
  // True while the process runs.
  bool Running();
  std::string Log() const;

 private:
  ServerProcess() = default;
  std::unique_ptr<ChildProcess> process_;
  std::string address_;
  std::string log_path_;
};

// The waymark-server binary of this build, or $WAYMARK_SERVER_BINARY when set (benches).
std::string ServerBinary();

// Exit code and output of a command run through the shell.
struct CommandResult {
  int code = -1;       // -1 when it did not exit normally
  std::string output;  // stdout, then stderr if `merge_stderr`
};
// Runs `<build>/bin/<binary> <args>` (args as a shell would split them); stderr joins stdout
// unless `merge_stderr` is false (then it goes to the test's own stderr).
CommandResult RunBinary(const std::string& binary, const std::string& args,
                        bool merge_stderr = true);
// A fresh temporary directory (removed by the caller or left for inspection).
std::string MakeTempDir(const std::string& prefix);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_SERVER_PROCESS_H_
