#ifndef WAYMARK_CLIENT_CLI_CLI_H_
#define WAYMARK_CLIENT_CLI_CLI_H_

#include <ostream>

namespace waymark::cli {

// The whole `waymark` command line: parses argv, runs the selected command and returns the process
// exit code. Output goes to `out` (results) and `err` (errors, progress).
int RunCli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
           bool err_is_tty);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_CLI_H_
