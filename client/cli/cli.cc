#include "client/cli/cli.h"

#include "client/cli/command.h"
#include "client/cli/server_address.h"
#include "client/cli/unknown_command.h"
#include "client/cli/vo_command.h"
#include "client/common/output.h"
#include "client/lib/fleet_target.h"

namespace waymark::cli {

int RunCli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
           bool err_is_tty) {
  CommandContext context{GlobalOptions{}, out, err, err_is_tty, /*credentials=*/nullptr};
  GlobalOptions& globals = context.globals;

  CLI::App app{"waymark: command line for the Waymark localization service"};
  app.name("waymark");
  // Inherited by the subcommands created below, so `waymark db list --json` works as well as
  // `waymark --json db list`.
  app.fallthrough();
  app.require_subcommand(1);
  app.add_option("--server", globals.server,
                 "Server address HOST[:PORT], [IPV6][:PORT] or unix:PATH (port 50051 if omitted); "
                 "several servers sharing a PostgreSQL database as HOST[:PORT],HOST[:PORT],... "
                 "(calls are spread over them, and go on when one is down)")
      ->envname("WAYMARK_SERVER")
      ->capture_default_str();
  app.add_flag("--json", globals.json, "Print one JSON document on stdout instead of tables");
  app.add_option("--timeout", globals.timeout_s,
                 "Deadline of each request in seconds, retries included (0 = none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--token", globals.token, "Bearer token for the server (from `waymark token create`)")
      ->envname("WAYMARK_TOKEN");
  app.add_flag("--tls", globals.use_tls, "Connect with TLS, trusting the system's CAs");
  app.add_option("--tls-ca", globals.tls.ca, "Connect with TLS, trusting this PEM CA")
      ->envname("WAYMARK_TLS_CA");
  app.add_option("--tls-cert", globals.tls.cert, "PEM client certificate (servers with mutual TLS)")
      ->envname("WAYMARK_CLIENT_CERT");
  app.add_option("--tls-key", globals.tls.key, "PEM key of --tls-cert")->envname("WAYMARK_CLIENT_KEY");
  app.add_option("--tls-server-name", globals.tls_server_name,
                 "Name the server's certificate carries, when not the address's host")
      ->envname("WAYMARK_TLS_SERVER_NAME");

  CommandRegistry registry;
  AddDbCommands(app, registry);
  AddCrossingCommands(app, registry);
  AddEnrollCommand(app, registry);
  AddRecognizeCommand(app, registry);
  AddEvalCommand(app, registry);
  AddEvalRelationsCommand(app, registry);
  AddEvalAteCommand(app, registry);
  AddSlamCommands(app, registry);
  AddSimCommands(app, registry);
  AddRobotCommand(app, registry);
  AddHealthCommand(app, registry);
  AddBenchLoadCommand(app, registry);
  AddTokenCommands(app, registry);
  AddBagCommands(app, registry);
  AddMapCommands(app, registry);
  AddVoCommands(app, registry);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (std::optional<int> code = ReportUnknownCommand(app, e, err)) return *code;
    return app.exit(e, out, err);
  }
  // Every command dials (and every error names) the completed address.
  absl::StatusOr<std::string> server = WithDefaultPort(globals.server);
  if (!server.ok()) return ReportError(context, server.status(), "--server / WAYMARK_SERVER");
  globals.server = *std::move(server);
  // Several servers: say now which one does not resolve, not later as a vague UNAVAILABLE.
  if (absl::Status fleet = client::ParseFleetTarget(globals.server).status(); !fleet.ok()) {
    return ReportError(context, fleet, "--server / WAYMARK_SERVER");
  }
  if (globals.use_tls || !globals.tls.ca.empty() || !globals.tls.cert.empty()) {
    auto credentials = client::MakeTlsCredentials(globals.tls);
    if (!credentials.ok()) {
      err << "error: " << credentials.status().message() << "\n";
      return kExitFailure;
    }
    context.credentials = *credentials;
  }
  return registry.RunParsed(context).value_or(kExitFailure);
}

}  // namespace waymark::cli
