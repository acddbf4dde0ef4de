#ifndef WAYMARK_TESTS_SUPPORT_SERVER_PROCESS_H_
#define WAYMARK_TESTS_SUPPORT_SERVER_PROCESS_H_

// Runs the real waymark-server binary for integration tests: on port 0, with its own database
// file, output captured to a log file that failing tests print.

#include <sys/types.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::testing {

class ServerProcess {
 public:
  // Starts `binary --listen 127.0.0.1:0 --db db_path args...` and waits (up to 60 s) for its
  // "listening on" line.
  // `listen` replaces 127.0.0.1:0, e.g. to restart a server on the port it had.
  static absl::StatusOr<std::unique_ptr<ServerProcess>> Start(const std::string& binary,
                                                              const std::string& db_path,
                                                              const std::vector<std::string>& args = {},
                                                              const std::string& listen = "127.0.0.1:0");
  ~ServerProcess();

  const std::string& address() const { return address_; }
  pid_t pid() const { return pid_; }
  // Sends `signal` and waits for the exit; returns the exit code (128 + signal if killed).
  int Stop(int signal);
  // True while the process runs.
  bool Running();
  std::string Log() const;

 private:
  ServerProcess() = default;
  pid_t pid_ = -1;
  std::string address_;
  std::string log_path_;
};

// The waymark-server binary of this build.
std::string ServerBinary();
// A fresh temporary directory (removed by the caller or left for inspection).
std::string MakeTempDir(const std::string& prefix);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_SERVER_PROCESS_H_
