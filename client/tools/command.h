#ifndef WAYMARK_CLIENT_TOOLS_COMMAND_H_
#define WAYMARK_CLIENT_TOOLS_COMMAND_H_

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "client/lib/channel.h"
#include "client/lib/crossing_client.h"
#include "client/lib/slam_client.h"

namespace waymark::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;

// Options every command accepts, before or after the command name.
struct GlobalOptions {
  std::string server = "127.0.0.1:50051";
  bool json = false;
  double timeout_s = 30;
  std::string token;            // bearer token (WAYMARK_TOKEN); empty = none
  client::TlsFiles tls;         // --tls-ca / --tls-cert / --tls-key; TLS when any is set
  bool use_tls = false;         // --tls: TLS with the system's CAs
  std::string tls_server_name;  // --tls-server-name
};

// What a command needs from its surroundings; streams are injected so tests can capture output.
struct CommandContext {
  GlobalOptions globals;
  std::ostream& out;
  std::ostream& err;
  bool err_is_tty = false;  // progress bars only when a person is watching
  // TLS credentials read from the --tls-* files once the command line is parsed; nullptr means
  // plaintext.
  std::shared_ptr<grpc::ChannelCredentials> credentials;

  // Channel settings from the global options: credentials, TLS server name, bearer token.
  client::ChannelOptions Channel() const;
  // A channel to globals.server with those settings.
  std::shared_ptr<grpc::Channel> MakeChannel() const;

  // A client for globals.server with globals.timeout_s on every unary call.
  std::unique_ptr<client::CrossingClient> Connect() const;
  // The same for SlamService.
  std::unique_ptr<client::SlamClient> ConnectSlam() const;
};

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

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_TOOLS_COMMAND_H_
