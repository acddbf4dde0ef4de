#include "client/tools/cli.h"

#include "client/tools/command.h"

namespace waymark::cli {

int RunCli(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
           bool err_is_tty) {
  CommandContext context{GlobalOptions{}, out, err, err_is_tty};
  GlobalOptions& globals = context.globals;

  CLI::App app{"waymark: command line for the Waymark localization service"};
  app.name("waymark");
  // Inherited by the subcommands created below, so `waymark db list --json` works as well as
  // `waymark --json db list`.
  app.fallthrough();
  app.require_subcommand(1);
  app.add_option("--server", globals.server, "Server address host:port")
      ->envname("WAYMARK_SERVER")
      ->capture_default_str();
  app.add_flag("--json", globals.json, "Print one JSON document on stdout instead of tables");
  app.add_option("--timeout", globals.timeout_s,
                 "Deadline of each request in seconds, retries included (0 = none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();

  CommandRegistry registry;
  AddDbCommands(app, registry);
  AddCrossingCommands(app, registry);
  AddEnrollCommand(app, registry);
  AddRecognizeCommand(app, registry);
  AddEvalCommand(app, registry);
  AddEvalRelationsCommand(app, registry);
  AddSlamCommands(app, registry);
  AddSimCommands(app, registry);
  AddRobotCommand(app, registry);
  AddHealthCommand(app, registry);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e, out, err);
  }
  return registry.RunParsed(context).value_or(kExitFailure);
}

}  // namespace waymark::cli
