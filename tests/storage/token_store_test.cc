// The SQLite TokenStore against real files: create and authenticate, what is (not) stored, revoked
// and expired tokens, listing, revoking, and upgrading a file written before tokens existed.

#include "storage/token_store.h"

#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "storage/migrations.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TempDir;

constexpr double kNow = 1.8e9;  // a fixed clock: tests pass `now` instead of sleeping

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(TokenStoreTest, RoleNamesRoundTrip) {
  for (TokenRole role : {TokenRole::kRobot, TokenRole::kMapper, TokenRole::kAdmin}) {
    ASSERT_OK_AND_ASSIGN(TokenRole parsed, ParseTokenRole(TokenRoleName(role)));
    EXPECT_EQ(parsed, role);
  }
  EXPECT_STREQ(TokenRoleName(TokenRole::kMapper), "mapper");
  EXPECT_EQ(CodeOf(ParseTokenRole("root")), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(ParseTokenRole("")), absl::StatusCode::kInvalidArgument);
}

TEST(TokenStoreTest, CreateThenAuthenticate) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(dir.File("w.db")));
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store->CreateToken("r1-token", "robot-1", TokenRole::kRobot, std::nullopt));
  EXPECT_EQ(created.secret.rfind("wm_", 0), 0u) << created.secret;
  EXPECT_EQ(created.secret.size(), 3u + 64u);
  EXPECT_GT(created.record.id, 0);
  EXPECT_GT(created.record.created_at, 0);
  EXPECT_FALSE(created.record.last_used_at.has_value());

  ASSERT_OK_AND_ASSIGN(TokenRecord got, store->Authenticate(created.secret, kNow));
  EXPECT_EQ(got.id, created.record.id);
  EXPECT_EQ(got.name, "r1-token");
  EXPECT_EQ(got.robot_id, "robot-1");
  EXPECT_EQ(got.role, TokenRole::kRobot);
  EXPECT_FALSE(got.revoked_at.has_value());
  EXPECT_EQ(got.last_used_at, kNow);

  // A second token gets a different secret, and each secret finds its own token.
  ASSERT_OK_AND_ASSIGN(CreatedToken other,
                       store->CreateToken("admin", "ops", TokenRole::kAdmin, kNow + 3600));
  EXPECT_NE(other.secret, created.secret);
  ASSERT_OK_AND_ASSIGN(TokenRecord admin, store->Authenticate(other.secret, kNow));
  EXPECT_EQ(admin.name, "admin");
  EXPECT_EQ(admin.role, TokenRole::kAdmin);
  EXPECT_EQ(admin.expires_at, kNow + 3600);
}

TEST(TokenStoreTest, LastUsedIsWrittenAtMostOnceAMinute) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  ASSERT_OK(store->Authenticate(created.secret, kNow));
  ASSERT_OK_AND_ASSIGN(TokenRecord soon, store->Authenticate(created.secret, kNow + 30));
  EXPECT_EQ(soon.last_used_at, kNow);
  ASSERT_OK_AND_ASSIGN(TokenRecord later, store->Authenticate(created.secret, kNow + 61));
  EXPECT_EQ(later.last_used_at, kNow + 61);
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store->ListTokens());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].last_used_at, kNow + 61);  // persisted, not only returned
}

TEST(TokenStoreTest, SecretIsNotStoredInTheFile) {
  TempDir dir;
  const std::string path = dir.File("w.db");
  std::string secret;
  {
    ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(path));
    ASSERT_OK_AND_ASSIGN(CreatedToken created, store->CreateToken("find-me-label", "robot-1",
                                                                  TokenRole::kRobot, std::nullopt));
    secret = created.secret;
  }
  // The WAL is folded into the file when the last connection closes; read both in case it is not.
  const std::string bytes = ReadBytes(path) + ReadBytes(path + "-wal");
  // The name is stored in the clear: finding it shows that the bytes searched are the right ones.
  EXPECT_NE(bytes.find("find-me-label"), std::string::npos);
  EXPECT_EQ(bytes.find(secret), std::string::npos);
  EXPECT_EQ(bytes.find(secret.substr(3)), std::string::npos);  // nor its random part alone

  ASSERT_OK_AND_ASSIGN(auto reopened, OpenSqliteTokenStore(path));
  EXPECT_OK(reopened->Authenticate(secret, kNow));
}

TEST(TokenStoreTest, WrongSecretIsUnauthenticated) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store->CreateToken("t", "robot-1", TokenRole::kMapper, std::nullopt));
  std::string wrong = created.secret;
  wrong.back() = wrong.back() == '0' ? '1' : '0';
  absl::StatusOr<TokenRecord> result = store->Authenticate(wrong, kNow);
  EXPECT_EQ(CodeOf(result), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(result.status().message(), "unknown token");
  EXPECT_EQ(CodeOf(store->Authenticate("", kNow)), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(CodeOf(store->Authenticate(created.secret.substr(3), kNow)),
            absl::StatusCode::kUnauthenticated);
  EXPECT_OK(store->Authenticate(created.secret, kNow));
}

TEST(TokenStoreTest, RevokedTokenIsUnauthenticatedAndRevokeIsIdempotent) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  ASSERT_OK_AND_ASSIGN(CreatedToken kept,
                       store->CreateToken("kept", "robot-1", TokenRole::kRobot, std::nullopt));
  ASSERT_OK_AND_ASSIGN(CreatedToken gone,
                       store->CreateToken("gone", "robot-2", TokenRole::kRobot, std::nullopt));
  ASSERT_OK(store->RevokeToken("gone"));
  absl::StatusOr<TokenRecord> result = store->Authenticate(gone.secret, kNow);
  EXPECT_EQ(CodeOf(result), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(result.status().message(), "token is revoked");
  EXPECT_OK(store->Authenticate(kept.secret, kNow));  // only the named token was revoked

  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> before, store->ListTokens());
  ASSERT_EQ(before.size(), 2u);
  ASSERT_TRUE(before[1].revoked_at.has_value());
  EXPECT_OK(store->RevokeToken("gone"));
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> after, store->ListTokens());
  EXPECT_EQ(after[1].revoked_at, before[1].revoked_at);  // the first revocation time stays
  EXPECT_FALSE(after[0].revoked_at.has_value());
}

TEST(TokenStoreTest, RevokeUnknownNameIsNotFound) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  ASSERT_OK(store->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  absl::Status status = store->RevokeToken("nope");
  EXPECT_EQ(status.code(), absl::StatusCode::kNotFound);
  EXPECT_NE(status.message().find("\"nope\""), absl::string_view::npos) << status;
}

TEST(TokenStoreTest, ExpiredTokenIsUnauthenticated) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store->CreateToken("t", "robot-1", TokenRole::kRobot, kNow + 100));
  EXPECT_OK(store->Authenticate(created.secret, kNow + 99));
  absl::StatusOr<TokenRecord> result = store->Authenticate(created.secret, kNow + 100);
  EXPECT_EQ(CodeOf(result), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(result.status().message(), "token has expired");
}

TEST(TokenStoreTest, InvalidArgumentsAndDuplicateName) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  EXPECT_EQ(CodeOf(store->CreateToken("", "robot-1", TokenRole::kRobot, std::nullopt)),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store->CreateToken("t", "", TokenRole::kRobot, std::nullopt)),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store->CreateToken("t", "robot-1", TokenRole::kRobot,
                                      std::numeric_limits<double>::quiet_NaN())),
            absl::StatusCode::kInvalidArgument);

  ASSERT_OK(store->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  absl::StatusOr<CreatedToken> dup = store->CreateToken("t", "robot-2", TokenRole::kAdmin, kNow);
  EXPECT_EQ(CodeOf(dup), absl::StatusCode::kAlreadyExists);
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store->ListTokens());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].robot_id, "robot-1");  // the first token is untouched
}

TEST(TokenStoreTest, ListShowsRolesInCreationOrder) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(":memory:"));
  ASSERT_OK(store->CreateToken("r", "robot-1", TokenRole::kRobot, std::nullopt));
  ASSERT_OK(store->CreateToken("m", "mapper-1", TokenRole::kMapper, kNow));
  ASSERT_OK(store->CreateToken("a", "ops", TokenRole::kAdmin, std::nullopt));
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store->ListTokens());
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(listed[0].name, "r");
  EXPECT_EQ(listed[0].role, TokenRole::kRobot);
  EXPECT_FALSE(listed[0].expires_at.has_value());
  EXPECT_EQ(listed[1].name, "m");
  EXPECT_EQ(listed[1].role, TokenRole::kMapper);
  EXPECT_EQ(listed[1].robot_id, "mapper-1");
  EXPECT_EQ(listed[1].expires_at, kNow);
  EXPECT_EQ(listed[2].name, "a");
  EXPECT_EQ(listed[2].role, TokenRole::kAdmin);
  EXPECT_LT(listed[0].id, listed[1].id);
  EXPECT_LT(listed[1].id, listed[2].id);
}

TEST(TokenStoreTest, UpgradesAFileWrittenBeforeTokens) {
  TempDir dir;
  const std::string path = dir.File("old.db");
  {
    // What a build with only the crossing and SLAM tables left behind, with some data in it.
    ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
    const std::vector<absl::string_view>& steps = SchemaMigrations();
    ASSERT_GE(steps.size(), 3u);
    ASSERT_OK(ApplyMigrations(connection, {steps[0], steps[1]}));
    ASSERT_OK(connection.Exec(
        "INSERT INTO crossing_db (name, params, created_at) VALUES ('campus', '{}', 1)"));
    ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
    ASSERT_EQ(version, 2);
  }
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(path));
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  EXPECT_OK(store->Authenticate(created.secret, kNow));

  ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_GE(version, 3);  // tokens arrived in v3; later migrations run too
  EXPECT_EQ(version, CurrentSchemaVersion());
  ASSERT_OK_AND_ASSIGN(sqlite::Statement count,
                       connection.Prepare("SELECT COUNT(*) FROM crossing_db"));
  ASSERT_OK_AND_ASSIGN(sqlite::StepResult step, count.Step());
  ASSERT_EQ(step, sqlite::StepResult::kRow);
  EXPECT_EQ(count.ColumnInt64(0), 1);  // the old data survived the upgrade
}

TEST(TokenStoreTest, SchemaRejectsAnUnknownRole) {
  // The CHECK constraint guards the file against writers other than this store.
  ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(":memory:"));
  ASSERT_OK(MigrateSchema(connection));
  EXPECT_FALSE(connection
                   .Exec("INSERT INTO tokens (name, robot_id, role, secret_hash, created_at) "
                         "VALUES ('x', 'r', 'root', x'00', 1)")
                   .ok());
  EXPECT_OK(
      connection.Exec("INSERT INTO tokens (name, robot_id, role, secret_hash, created_at) "
                      "VALUES ('x', 'r', 'robot', x'00', 1)"));
}

}  // namespace
}  // namespace waymark::storage
