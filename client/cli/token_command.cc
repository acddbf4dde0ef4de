// `waymark token create|list|revoke`: bearer tokens, through the server's TokenService (admin
// token needed). The very first admin token is made on the server host with
// `waymark-server --db FILE token create admin --role admin`.
#include <fmt/format.h>

#include <memory>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/time/time.h"
#include "client/lib/token_client.h"
#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"

namespace waymark::cli {
namespace {

struct TokenArgs {
  std::string name;
  std::string robot_id;
  std::string role = "robot";
  double expires_days = 0;
};

client::TokenClient Connect(const CommandContext& context) {
  client::TokenClientOptions options;
  options.timeout = context.globals.timeout_s > 0 ? absl::Seconds(context.globals.timeout_s)
                                                  : absl::InfiniteDuration();
  return client::TokenClient(context.MakeChannel(), options);
}

std::string FormatUnix(double seconds) {
  if (seconds <= 0) return "-";
  return absl::FormatTime("%Y-%m-%d %H:%M", absl::FromUnixSeconds(static_cast<int64_t>(seconds)),
                          absl::LocalTimeZone());
}

std::string RoleName(v1::TokenRole role) {
  return absl::AsciiStrToLower(v1::TokenRole_Name(role));
}

int RunCreate(CommandContext& context, const TokenArgs& args) {
  v1::TokenRole role = v1::TOKEN_ROLE_UNSPECIFIED;
  if (!v1::TokenRole_Parse(absl::AsciiStrToUpper(args.role), &role) ||
      role == v1::TOKEN_ROLE_UNSPECIFIED) {
    return ReportError(context,
                       absl::InvalidArgumentError(fmt::format(
                           "unknown role '{}' (robot, mapper, admin or viewer)", args.role)));
  }
  auto created = Connect(context).CreateToken(args.name, args.robot_id, role,
                                              absl::Seconds(args.expires_days * 86400.0));
  if (!created.ok()) return ReportError(context, created.status(), args.name);
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*created));
    return kExitOk;
  }
  context.err << fmt::format(
      "created {} token '{}' for robot '{}' (expires {}); the secret is shown only now:\n",
      RoleName(created->token().role()), created->token().name(), created->token().robot_id(),
      FormatUnix(created->token().expires_at_unix()));
  context.out << created->secret() << "\n";
  return kExitOk;
}

int RunTokenList(CommandContext& context) {
  auto list = Connect(context).ListTokens();
  if (!list.ok()) return ReportError(context, list.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*list));
    return kExitOk;
  }
  Table table({{"name"}, {"robot"}, {"role"}, {"created"}, {"expires"}, {"revoked"}, {"last used"}});
  for (const v1::Token& token : list->tokens()) {
    table.AddRow({token.name(), token.robot_id(), RoleName(token.role()),
                  FormatUnix(token.created_at_unix()), FormatUnix(token.expires_at_unix()),
                  FormatUnix(token.revoked_at_unix()), FormatUnix(token.last_used_at_unix())});
  }
  table.Print(context.out);
  return kExitOk;
}

int RunRevoke(CommandContext& context, const std::string& name) {
  auto revoked = Connect(context).RevokeToken(name);
  if (!revoked.ok()) return ReportError(context, revoked.status(), name);
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*revoked));
  } else {
    context.out << "revoked token " << name << "\n";
  }
  return kExitOk;
}

}  // namespace

void AddTokenCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* token = app.add_subcommand("token", "Create, list and revoke bearer tokens (admin)");
  token->require_subcommand(1);
  auto args = std::make_shared<TokenArgs>();

  CLI::App* create = token->add_subcommand("create", "Create a token; prints its secret once");
  create->add_option("NAME", args->name, "Unique token name, e.g. the robot's name")->required();
  create
      ->add_option("--role", args->role,
                   "robot, mapper, admin or viewer (viewer: only watches, e.g. the live view)")
      ->capture_default_str();
  create->add_option("--robot-id", args->robot_id, "Robot the token speaks for (default: NAME)");
  create->add_option("--expires-days", args->expires_days, "Days until it expires (0 = never)")
      ->check(CLI::NonNegativeNumber);
  registry.Add(create, [args](CommandContext& context) { return RunCreate(context, *args); });

  CLI::App* list = token->add_subcommand("list", "List tokens (never their secrets)");
  registry.Add(list, [](CommandContext& context) { return RunTokenList(context); });

  CLI::App* revoke = token->add_subcommand("revoke", "Revoke a token at once");
  revoke->add_option("NAME", args->name, "Token name")->required();
  registry.Add(revoke, [args](CommandContext& context) { return RunRevoke(context, args->name); });
}

}  // namespace waymark::cli
