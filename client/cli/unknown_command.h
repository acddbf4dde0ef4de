#ifndef WAYMARK_CLIENT_CLI_UNKNOWN_COMMAND_H_
#define WAYMARK_CLIENT_CLI_UNKNOWN_COMMAND_H_

// What the command line says when it cannot tell which command to run: `waymark frobnicate` or
// `waymark slam frob` name the word it did not know and list the commands that exist there
// (CLI11 alone says "A subcommand is required" and names nothing).

#include <CLI/CLI.hpp>
#include <optional>
#include <ostream>

namespace waymark::cli {

// For a parse error of `app` that comes from a missing or unknown (sub)command: prints
// "error: unknown command 'WORD'" (or "error: a command is required") and the commands of the
// deepest group given, then returns the exit code. nullopt for any other parse error, which
// CLI11 reports itself.
std::optional<int> ReportUnknownCommand(const CLI::App& app, const CLI::ParseError& error,
                                        std::ostream& err);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_UNKNOWN_COMMAND_H_
