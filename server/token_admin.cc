#include "server/token_admin.h"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "storage/open_stores.h"
#include "storage/store_util.h"
#include "storage/token_store.h"

namespace waymark::server {
namespace {

std::string FormatUnix(std::optional<double> seconds) {
  if (!seconds.has_value()) return "-";
  return absl::FormatTime("%Y-%m-%d %H:%M:%S", absl::FromUnixSeconds(static_cast<int64_t>(*seconds)),
                          absl::UTCTimeZone());
}

int Create(storage::TokenStore& store, const TokenAdminFlags& flags) {
  absl::StatusOr<storage::TokenRole> role = storage::ParseTokenRole(flags.role);
  if (!role.ok()) {
    std::cerr << "error: " << role.status().message() << "\n";
    return 2;
  }
  std::optional<double> expires_at;
  if (flags.expires_days > 0) expires_at = storage::NowSeconds() + flags.expires_days * 86400.0;
  const std::string robot_id = flags.robot_id.empty() ? flags.name : flags.robot_id;
  auto created = store.CreateToken(flags.name, robot_id, *role, expires_at);
  if (!created.ok()) {
    std::cerr << "error: " << created.status().message() << "\n";
    return 1;
  }
  std::cerr << "created " << storage::TokenRoleName(*role) << " token \"" << flags.name
            << "\" for robot \"" << robot_id << "\" (expires " << FormatUnix(expires_at)
            << " UTC). The secret below is shown only now:\n";
  std::cout << created->secret << std::endl;
  return 0;
}

int List(storage::TokenStore& store) {
  auto tokens = store.ListTokens();
  if (!tokens.ok()) {
    std::cerr << "error: " << tokens.status().message() << "\n";
    return 1;
  }
  std::printf("%-20s %-20s %-7s %-19s %-19s %-19s %-19s\n", "NAME", "ROBOT", "ROLE",
              "CREATED (UTC)", "EXPIRES", "REVOKED", "LAST USED");
  for (const storage::TokenRecord& token : *tokens) {
    std::printf("%-20s %-20s %-7s %-19s %-19s %-19s %-19s\n", token.name.c_str(),
                token.robot_id.c_str(), storage::TokenRoleName(token.role),
                FormatUnix(token.created_at).c_str(), FormatUnix(token.expires_at).c_str(),
                FormatUnix(token.revoked_at).c_str(), FormatUnix(token.last_used_at).c_str());
  }
  return 0;
}

}  // namespace

CLI::App* AddTokenAdminCommands(CLI::App& app, TokenAdminFlags* flags) {
  CLI::App* token = app.add_subcommand(
      "token", "manage bearer tokens directly in the database file (also while serving)");
  token->require_subcommand(1);
  CLI::App* create = token->add_subcommand("create", "create a token and print its secret once");
  create->add_option("name", flags->name, "unique token name, e.g. the robot's name")->required();
  create
      ->add_option("--role", flags->role,
                   "robot, mapper, admin or viewer (viewer: only watches, e.g. the live view)")
      ->capture_default_str();
  create->add_option("--robot-id", flags->robot_id, "robot the token speaks for (default: name)");
  create->add_option("--expires-days", flags->expires_days, "days until it expires (0 = never)")
      ->check(CLI::NonNegativeNumber);
  token->add_subcommand("list", "list tokens (never their secrets)");
  CLI::App* revoke = token->add_subcommand("revoke", "revoke a token");
  revoke->add_option("name", flags->name, "token name")->required();
  return token;
}

int RunTokenAdmin(CLI::App* token_group, const TokenAdminFlags& flags, const std::string& db) {
  auto store = storage::OpenTokenStore(db);
  if (!store.ok()) {
    std::cerr << "error: cannot open database " << storage::PrintableDatabase(db) << ": "
              << store.status().message() << "\n";
    return 2;
  }
  if (token_group->got_subcommand("create")) return Create(**store, flags);
  if (token_group->got_subcommand("list")) return List(**store);
  if (absl::Status s = (*store)->RevokeToken(flags.name); !s.ok()) {
    std::cerr << "error: " << s.message() << "\n";
    return 1;
  }
  std::cerr << "revoked token \"" << flags.name << "\"\n";
  return 0;
}

}  // namespace waymark::server
