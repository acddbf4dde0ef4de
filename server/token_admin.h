#ifndef WAYMARK_SERVER_TOKEN_ADMIN_H_
#define WAYMARK_SERVER_TOKEN_ADMIN_H_

// `waymark-server --db FILE token create|list|revoke`: token management straight on the database
// file, for the first admin token (nobody can call TokenService before one exists) and for
// operators with shell access to the server. Safe while a server runs on the same file (SQLite
// WAL); a revocation reaches a running server within its token cache time (5 s).

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

namespace waymark::server {

struct TokenAdminFlags {
  std::string name;
  std::string robot_id;  // empty = the name
  std::string role = "robot";
  double expires_days = 0;  // 0 = never
};

// Adds the `token` subcommands to `app`; returns the group so main can tell it was selected.
CLI::App* AddTokenAdminCommands(CLI::App& app, TokenAdminFlags* flags);

// Runs the selected `token` subcommand on the database `db`; the process exit code.
int RunTokenAdmin(CLI::App* token_group, const TokenAdminFlags& flags, const std::string& db);

}  // namespace waymark::server

#endif  // WAYMARK_SERVER_TOKEN_ADMIN_H_
