#include "client/common/command_context.h"

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
  // A server of a fleet that names another as the session's: go there with the same settings.
  options.connect = [channel = Channel()](const std::string& address) {
    return std::shared_ptr<grpc::ChannelInterface>(client::MakeChannel(address, channel));
  };
  return std::make_unique<client::SlamClient>(MakeChannel(), options);
}

}  // namespace waymark::cli
