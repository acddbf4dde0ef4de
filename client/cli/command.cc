#include "client/cli/command.h"


namespace waymark::cli {

std::optional<int> CommandRegistry::RunParsed(CommandContext& context) const {
  const CommandFn* selected = nullptr;
  int selected_depth = -1;
  for (const auto& [command, run] : commands_) {
    if (!command->parsed()) continue;
    int depth = 0;
    for (const CLI::App* parent = command->get_parent(); parent != nullptr;
         parent = parent->get_parent()) {
      ++depth;
    }
    if (depth > selected_depth) {
      selected = &run;
      selected_depth = depth;
    }
  }
  if (selected == nullptr) return std::nullopt;
  return (*selected)(context);
}

}  // namespace waymark::cli
