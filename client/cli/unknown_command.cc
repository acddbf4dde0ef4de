#include "client/cli/unknown_command.h"

#include <fmt/format.h>

#include <algorithm>
#include <string>
#include <vector>

namespace waymark::cli {
namespace {

// The group the command line got to: `app`, or its deepest parsed subcommand.
const CLI::App* DeepestParsed(const CLI::App& app) {
  const CLI::App* group = &app;
  for (bool descended = true; descended;) {
    descended = false;
    for (const CLI::App* sub : group->get_subcommands([](const CLI::App*) { return true; })) {
      if (sub->parsed()) {
        group = sub;
        descended = true;
        break;
      }
    }
  }
  return group;
}

// "waymark slam": the names from the root to `group`.
std::string CommandPath(const CLI::App* group) {
  std::string path = group->get_name();
  for (const CLI::App* parent = group->get_parent(); parent != nullptr;
       parent = parent->get_parent()) {
    path = parent->get_name() + " " + path;
  }
  return path;
}

}  // namespace

std::optional<int> ReportUnknownCommand(const CLI::App& app, const CLI::ParseError& error,
                                        std::ostream& err) {
  // CLI11 raises RequiredError when a group's command is missing (an unknown word is not taken
  // for one), and ExtrasError when the word is left over where no command is required.
  if (dynamic_cast<const CLI::RequiredError*>(&error) == nullptr &&
      dynamic_cast<const CLI::ExtrasError*>(&error) == nullptr) {
    return std::nullopt;
  }
  const CLI::App* group = DeepestParsed(app);
  std::vector<const CLI::App*> commands =
      group->get_subcommands([](const CLI::App* sub) { return !sub->get_group().empty(); });
  // A leaf command, or a group that is a command itself (`eval NAME DIR`): its own arguments are
  // wrong, and CLI11 says which.
  if (commands.empty() || group->get_require_subcommand_min() == 0) return std::nullopt;
  // The first word that is not an option is the command the user meant.
  std::optional<std::string> word;
  for (const std::string& arg : app.remaining(/*recurse=*/true)) {
    if (!arg.empty() && arg[0] != '-') {
      word = arg;
      break;
    }
  }
  if (!word && error.what() != std::string("A subcommand is required")) {
    return std::nullopt;  // a required option, not the command, is missing
  }
  const std::string path = CommandPath(group);
  if (word) {
    err << fmt::format("error: unknown command '{}'{}\n", *word,
                       group == &app ? "" : fmt::format(" for '{}'", path));
  } else {
    err << fmt::format("error: '{}' needs a command\n", path);
  }
  err << fmt::format("commands{}:\n", group == &app ? "" : fmt::format(" of '{}'", path));
  size_t width = 0;
  for (const CLI::App* command : commands) width = std::max(width, command->get_name().size());
  for (const CLI::App* command : commands) {
    err << fmt::format("  {:<{}}  {}\n", command->get_name(), width, command->get_description());
  }
  err << fmt::format("run '{} --help' for more\n", path);
  return error.get_exit_code();
}

}  // namespace waymark::cli
