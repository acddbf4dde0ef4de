#ifndef WAYMARK_CLIENT_COMMON_COMMAND_CONTEXT_H_
#define WAYMARK_CLIENT_COMMON_COMMAND_CONTEXT_H_

// What every client job needs from its surroundings: the global options (server, output format,
// credentials) and the streams it prints to. The command line fills it in (client/cli); the
// session drivers and metrics below the command line take it so they can connect and report
// without knowing about the command line.

#include <memory>
#include <ostream>
#include <string>

#include "client/lib/channel.h"
#include "client/lib/crossing_client.h"
#include "client/lib/slam_client.h"

namespace waymark::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
// Stopped by SIGINT/SIGTERM before the work was done (128 + SIGINT, as shells report it).
inline constexpr int kExitInterrupted = 130;
// `robot --mode active`: the session said STUCK (the robot cannot go on; it was stopped). Not 2,
// which shells and many tools use for wrong usage, so a script can tell the two apart.
inline constexpr int kExitExplorationStuck = 3;
// `slam replay`: the run finished and wrote its outputs, but the final map contradicts itself
// (its self-check failed: a fold or a doubled corridor; --allow-inconsistent-map exits 0). The same
// number as STUCK: a finished run whose result is not good, which a script tells from an error (1).
inline constexpr int kExitInconsistentMap = 3;

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

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_COMMAND_CONTEXT_H_
