// `waymark health [--service NAME]`: the gRPC health check, for container HEALTHCHECKs and
// scripts. Exit 0 when SERVING, 1 otherwise (not serving, unknown service, unreachable).
#include <memory>
#include <string>

#include "client/lib/health_client.h"
#include "client/cli/command.h"
#include "client/common/output.h"

namespace waymark::cli {
namespace {

int RunHealth(CommandContext& context, const std::string& service) {
  const absl::Duration timeout =
      context.globals.timeout_s > 0 ? absl::Seconds(context.globals.timeout_s) : absl::Seconds(30);
  auto status = client::CheckHealth(context.MakeChannel(), service, timeout);
  if (!status.ok()) {
    return ReportError(context, status.status(),
                       service.empty() ? context.globals.server : service);
  }
  const std::string name = grpc::health::v1::HealthCheckResponse::ServingStatus_Name(*status);
  const bool serving = *status == grpc::health::v1::HealthCheckResponse::SERVING;
  if (context.globals.json) {
    PrintJson(context.out, {{"server", context.globals.server},
                            {"service", service},
                            {"status", name},
                            {"serving", serving}});
  } else {
    context.out << name << "\n";
  }
  return serving ? kExitOk : kExitFailure;
}

}  // namespace

void AddHealthCommand(CLI::App& app, CommandRegistry& registry) {
  auto service = std::make_shared<std::string>();
  CLI::App* health = app.add_subcommand(
      "health",
      "Ask the server's gRPC health service; exit 0 when SERVING (for container health checks)");
  health->add_option("--service", *service,
                     "A service to ask about, e.g. waymark.v1.SlamService (default: the server)");
  registry.Add(health, [service](CommandContext& context) { return RunHealth(context, *service); });
}

}  // namespace waymark::cli
