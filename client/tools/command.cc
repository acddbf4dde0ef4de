#include "client/tools/command.h"

#include "client/lib/channel.h"

namespace waymark::cli {

std::unique_ptr<client::CrossingClient> CommandContext::Connect() const {
  client::CrossingClientOptions options;
  options.timeout =
      globals.timeout_s > 0 ? absl::Seconds(globals.timeout_s) : absl::InfiniteDuration();
  return std::make_unique<client::CrossingClient>(client::MakeChannel(globals.server), options);
}

std::optional<int> CommandRegistry::RunParsed(CommandContext& context) const {
  for (const auto& [command, run] : commands_) {
    if (command->parsed()) return run(context);
  }
  return std::nullopt;
}

}  // namespace waymark::cli
