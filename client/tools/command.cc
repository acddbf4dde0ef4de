#include "client/tools/command.h"

#include "client/lib/channel.h"

namespace waymark::cli {

client::ChannelOptions CommandContext::Channel() const {
  client::ChannelOptions options;
  options.credentials = credentials;
  options.tls_server_name = globals.tls_server_name;
  options.bearer_token = globals.token;
  return options;
}

std::shared_ptr<grpc::Channel> CommandContext::MakeChannel() const {
  return client::MakeChannel(globals.server, Channel());
}

std::unique_ptr<client::CrossingClient> CommandContext::Connect() const {
  client::CrossingClientOptions options;
  options.timeout =
      globals.timeout_s > 0 ? absl::Seconds(globals.timeout_s) : absl::InfiniteDuration();
  return std::make_unique<client::CrossingClient>(MakeChannel(), options);
}

std::unique_ptr<client::SlamClient> CommandContext::ConnectSlam() const {
  client::SlamClientOptions options;
  options.timeout =
      globals.timeout_s > 0 ? absl::Seconds(globals.timeout_s) : absl::InfiniteDuration();
  return std::make_unique<client::SlamClient>(MakeChannel(), options);
}

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
