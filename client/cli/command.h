#ifndef WAYMARK_CLIENT_CLI_COMMAND_H_
#define WAYMARK_CLIENT_CLI_COMMAND_H_

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "client/common/command_context.h"

namespace waymark::cli {

using CommandFn = std::function<int(CommandContext&)>;

// Leaf commands and what they run. Commands run after CLI11 has checked every requirement, which
// CLI11's own callbacks do not guarantee (they run before the requirement checks).
class CommandRegistry {
 public:
  void Add(CLI::App* command, CommandFn run) { commands_.emplace_back(command, std::move(run)); }
  // Runs the command the command line selected: the deepest parsed one, so a group that is itself
  // a command (`eval NAME DIR`) can also hold subcommands (`eval relations ...`); nullopt if none
  // was selected.
  std::optional<int> RunParsed(CommandContext& context) const;

 private:
  std::vector<std::pair<CLI::App*, CommandFn>> commands_;
};

// One registration function per command group (db_commands.cc, crossing_commands.cc, ...).
void AddDbCommands(CLI::App& app, CommandRegistry& registry);
void AddCrossingCommands(CLI::App& app, CommandRegistry& registry);
void AddEnrollCommand(CLI::App& app, CommandRegistry& registry);
void AddRecognizeCommand(CLI::App& app, CommandRegistry& registry);
void AddEvalCommand(CLI::App& app, CommandRegistry& registry);
// `eval relations` (relations_command.cc); call after AddEvalCommand.
void AddEvalRelationsCommand(CLI::App& app, CommandRegistry& registry);
// `eval ate` (ate_command.cc); call after AddEvalCommand.
void AddEvalAteCommand(CLI::App& app, CommandRegistry& registry);
void AddSlamCommands(CLI::App& app, CommandRegistry& registry);
// `sim explore`, `sim worlds` (sim_commands.cc).
void AddSimCommands(CLI::App& app, CommandRegistry& registry);
// `robot` (robot_command.cc).
void AddRobotCommand(CLI::App& app, CommandRegistry& registry);
// `health` (health_command.cc).
void AddHealthCommand(CLI::App& app, CommandRegistry& registry);
// `bench load` (bench_load_command.cc).
void AddBenchLoadCommand(CLI::App& app, CommandRegistry& registry);
// `token create|list|revoke` (token_command.cc).
void AddTokenCommands(CLI::App& app, CommandRegistry& registry);
// `bag info` (bag_command.cc).
void AddBagCommands(CLI::App& app, CommandRegistry& registry);
// `waymark map create|list|show|grid|delete`: maps shared by robots (map_command.cc).
void AddMapCommands(CLI::App& app, CommandRegistry& registry);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_COMMAND_H_
