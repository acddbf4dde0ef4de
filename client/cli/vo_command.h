#ifndef WAYMARK_CLIENT_CLI_VO_COMMAND_H_
#define WAYMARK_CLIENT_CLI_VO_COMMAND_H_

#include <CLI/CLI.hpp>

#include "client/cli/command.h"

namespace waymark::cli {

// `vo run SEQ_DIR` (vo_command.cc, vo_run.cc): visual odometry sessions from image sequences.
void AddVoCommands(CLI::App& app, CommandRegistry& registry);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_VO_COMMAND_H_
