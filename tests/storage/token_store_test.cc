// The TokenStore on both backends (a SQLite file, a PostgreSQL database): create and
// authenticate, what is (not) stored, revoked and expired tokens, listing, revoking, the schema's
// role check; and, SQLite only, upgrading a file written before tokens existed.

#include "storage/token_store.h"

#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "storage/migrations.h"
#include "storage/open_stores.h"
#include "storage/postgres/pg.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::Backend;
using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TempDir;
using ::waymark::storage::testing::TestDatabase;

constexpr double kNow = 1.8e9;  // a fixed clock: tests pass `now` instead of sleeping

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Everything the database holds about tokens, as bytes to search. SQLite: the file and its WAL
// (folded into the file when the last connection closes; read both in case it is not).
// PostgreSQL: every row of the tokens table as text, and the raw bytes of the hash column (whose
// text form is hex, so a secret stored there as bytes would not show in the text).
absl::StatusOr<std::string> StoredTokenBytes(const TestDatabase& database) {
  if (database.backend() == Backend::kSqlite) {
    return ReadBytes(database.db()) + ReadBytes(database.db() + "-wal");
  }
  absl::StatusOr<std::unique_ptr<pg::Connection>> connection = pg::Connection::Open(database.db());
  if (!connection.ok()) return connection.status();
  absl::StatusOr<pg::Result> rows =
      (*connection)->Execute("SELECT t::text, t.secret_hash FROM tokens t");
  if (!rows.ok()) return rows.status();
  std::string bytes;
  for (int row = 0; row < rows->rows(); ++row) {
    absl::StrAppend(&bytes, rows->Bytes(row, 0), "\n", rows->Bytes(row, 1), "\n");
  }
  return bytes;
}

// The suite runs on both backends (store_backend.h).
class TokenStoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  TokenStoreTest() : database_(GetParam(), "w.db") {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    ASSERT_OK_AND_ASSIGN(store_, OpenTokenStore(database_.db()));
  }

  TestDatabase database_;
  std::unique_ptr<TokenStore> store_;
};

INSTANTIATE_TEST_SUITE_P(Backends, TokenStoreTest, testing::kBothBackends, testing::BackendName);

TEST(TokenRoleTest, RoleNamesRoundTrip) {
  for (TokenRole role :
       {TokenRole::kRobot, TokenRole::kMapper, TokenRole::kAdmin, TokenRole::kViewer}) {
    ASSERT_OK_AND_ASSIGN(TokenRole parsed, ParseTokenRole(TokenRoleName(role)));
    EXPECT_EQ(parsed, role);
  }
  EXPECT_STREQ(TokenRoleName(TokenRole::kMapper), "mapper");
  EXPECT_EQ(CodeOf(ParseTokenRole("root")), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(ParseTokenRole("")), absl::StatusCode::kInvalidArgument);
}

TEST_P(TokenStoreTest, CreateThenAuthenticate) {
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store_->CreateToken("r1-token", "robot-1", TokenRole::kRobot, std::nullopt));
  EXPECT_EQ(created.secret.rfind("wm_", 0), 0u) << created.secret;
  EXPECT_EQ(created.secret.size(), 3u + 64u);
  EXPECT_GT(created.record.id, 0);
  EXPECT_GT(created.record.created_at, 0);
  EXPECT_FALSE(created.record.last_used_at.has_value());

  ASSERT_OK_AND_ASSIGN(TokenRecord got, store_->Authenticate(created.secret, kNow));
  EXPECT_EQ(got.id, created.record.id);
  EXPECT_EQ(got.name, "r1-token");
  EXPECT_EQ(got.robot_id, "robot-1");
  EXPECT_EQ(got.role, TokenRole::kRobot);
  EXPECT_FALSE(got.revoked_at.has_value());
  EXPECT_EQ(got.last_used_at, kNow);

  // A second token gets a different secret, and each secret finds its own token.
  ASSERT_OK_AND_ASSIGN(CreatedToken other,
                       store_->CreateToken("admin", "ops", TokenRole::kAdmin, kNow + 3600));
  EXPECT_NE(other.secret, created.secret);
  ASSERT_OK_AND_ASSIGN(TokenRecord admin, store_->Authenticate(other.secret, kNow));
  EXPECT_EQ(admin.name, "admin");
  EXPECT_EQ(admin.role, TokenRole::kAdmin);
  EXPECT_EQ(admin.expires_at, kNow + 3600);
}

// Issue 37: the viewer role (the live view) is stored and read back by both backends: their
// schemas' CHECK on the role accepts it after the migration.
TEST_P(TokenStoreTest, ViewerTokensAreStoredAndAuthenticate) {
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store_->CreateToken("wall-screen", "ops", TokenRole::kViewer, std::nullopt));
  ASSERT_OK_AND_ASSIGN(TokenRecord got, store_->Authenticate(created.secret, kNow));
  EXPECT_EQ(got.role, TokenRole::kViewer);
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store_->ListTokens());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].role, TokenRole::kViewer);
}

TEST_P(TokenStoreTest, LastUsedIsWrittenAtMostOnceAMinute) {
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store_->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  ASSERT_OK(store_->Authenticate(created.secret, kNow));
  ASSERT_OK_AND_ASSIGN(TokenRecord soon, store_->Authenticate(created.secret, kNow + 30));
  EXPECT_EQ(soon.last_used_at, kNow);
  ASSERT_OK_AND_ASSIGN(TokenRecord later, store_->Authenticate(created.secret, kNow + 61));
  EXPECT_EQ(later.last_used_at, kNow + 61);
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store_->ListTokens());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].last_used_at, kNow + 61);  // persisted, not only returned
}

TEST_P(TokenStoreTest, SecretIsNotStored) {
  ASSERT_OK_AND_ASSIGN(CreatedToken created, store_->CreateToken("find-me-label", "robot-1",
                                                                 TokenRole::kRobot, std::nullopt));
  const std::string secret = created.secret;
  store_.reset();
  ASSERT_OK_AND_ASSIGN(const std::string bytes, StoredTokenBytes(database_));
  // The name is stored in the clear: finding it shows that the bytes searched are the right ones.
  EXPECT_NE(bytes.find("find-me-label"), std::string::npos);
  EXPECT_EQ(bytes.find(secret), std::string::npos);
  EXPECT_EQ(bytes.find(secret.substr(3)), std::string::npos);  // nor its random part alone

  ASSERT_OK_AND_ASSIGN(auto reopened, OpenTokenStore(database_.db()));
  EXPECT_OK(reopened->Authenticate(secret, kNow));
}

TEST_P(TokenStoreTest, WrongSecretIsUnauthenticated) {
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store_->CreateToken("t", "robot-1", TokenRole::kMapper, std::nullopt));
  std::string wrong = created.secret;
  wrong.back() = wrong.back() == '0' ? '1' : '0';
  absl::StatusOr<TokenRecord> result = store_->Authenticate(wrong, kNow);
  EXPECT_EQ(CodeOf(result), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(result.status().message(), "unknown token");
  EXPECT_EQ(CodeOf(store_->Authenticate("", kNow)), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(CodeOf(store_->Authenticate(created.secret.substr(3), kNow)),
            absl::StatusCode::kUnauthenticated);
  EXPECT_OK(store_->Authenticate(created.secret, kNow));
}

TEST_P(TokenStoreTest, RevokedTokenIsUnauthenticatedAndRevokeIsIdempotent) {
  ASSERT_OK_AND_ASSIGN(CreatedToken kept,
                       store_->CreateToken("kept", "robot-1", TokenRole::kRobot, std::nullopt));
  ASSERT_OK_AND_ASSIGN(CreatedToken gone,
                       store_->CreateToken("gone", "robot-2", TokenRole::kRobot, std::nullopt));
  ASSERT_OK(store_->RevokeToken("gone"));
  absl::StatusOr<TokenRecord> result = store_->Authenticate(gone.secret, kNow);
  EXPECT_EQ(CodeOf(result), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(result.status().message(), "token is revoked");
  EXPECT_OK(store_->Authenticate(kept.secret, kNow));  // only the named token was revoked

  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> before, store_->ListTokens());
  ASSERT_EQ(before.size(), 2u);
  ASSERT_TRUE(before[1].revoked_at.has_value());
  EXPECT_OK(store_->RevokeToken("gone"));
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> after, store_->ListTokens());
  EXPECT_EQ(after[1].revoked_at, before[1].revoked_at);  // the first revocation time stays
  EXPECT_FALSE(after[0].revoked_at.has_value());
}

TEST_P(TokenStoreTest, RevokeUnknownNameIsNotFound) {
  ASSERT_OK(store_->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  absl::Status status = store_->RevokeToken("nope");
  EXPECT_EQ(status.code(), absl::StatusCode::kNotFound);
  EXPECT_NE(status.message().find("\"nope\""), absl::string_view::npos) << status;
}

TEST_P(TokenStoreTest, ExpiredTokenIsUnauthenticated) {
  ASSERT_OK_AND_ASSIGN(CreatedToken created,
                       store_->CreateToken("t", "robot-1", TokenRole::kRobot, kNow + 100));
  EXPECT_OK(store_->Authenticate(created.secret, kNow + 99));
  absl::StatusOr<TokenRecord> result = store_->Authenticate(created.secret, kNow + 100);
  EXPECT_EQ(CodeOf(result), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(result.status().message(), "token has expired");
}

TEST_P(TokenStoreTest, InvalidArgumentsAndDuplicateName) {
  EXPECT_EQ(CodeOf(store_->CreateToken("", "robot-1", TokenRole::kRobot, std::nullopt)),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store_->CreateToken("t", "", TokenRole::kRobot, std::nullopt)),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store_->CreateToken("t", "robot-1", TokenRole::kRobot,
                                       std::numeric_limits<double>::quiet_NaN())),
            absl::StatusCode::kInvalidArgument);

  ASSERT_OK(store_->CreateToken("t", "robot-1", TokenRole::kRobot, std::nullopt));
  absl::StatusOr<CreatedToken> dup = store_->CreateToken("t", "robot-2", TokenRole::kAdmin, kNow);
  EXPECT_EQ(CodeOf(dup), absl::StatusCode::kAlreadyExists);
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store_->ListTokens());
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].robot_id, "robot-1");  // the first token is untouched
}

TEST_P(TokenStoreTest, ListShowsRolesInCreationOrder) {
  ASSERT_OK(store_->CreateToken("r", "robot-1", TokenRole::kRobot, std::nullopt));
  ASSERT_OK(store_->CreateToken("m", "mapper-1", TokenRole::kMapper, kNow));
  ASSERT_OK(store_->CreateToken("a", "ops", TokenRole::kAdmin, std::nullopt));
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> listed, store_->ListTokens());
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

// SQLite only: PostgreSQL support starts at a schema that has tokens.
TEST(TokenStoreSqliteTest, UpgradesAFileWrittenBeforeTokens) {
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

// SQLite only: a file from before viewer tokens (schema v13) keeps its tokens and takes viewers.
TEST(TokenStoreSqliteTest, UpgradesAFileWrittenBeforeViewerTokens) {
  TempDir dir;
  const std::string path = dir.File("v13.db");
  {
    ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
    const std::vector<absl::string_view>& steps = SchemaMigrations();
    ASSERT_GE(steps.size(), 14u);
    ASSERT_OK(ApplyMigrations(connection, {steps.begin(), steps.begin() + 13}));
    ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
    ASSERT_EQ(version, 13);
    const std::string insert =
        "INSERT INTO tokens (name, robot_id, role, secret_hash, created_at, revoked_at) VALUES ";
    ASSERT_OK(connection.Exec(insert + "('old-robot', 'robot-1', 'robot', x'01', 1, NULL)"));
    ASSERT_OK(connection.Exec(insert + "('old-admin', 'ops', 'admin', x'02', 2, 3)"));
    // v13's CHECK refuses the role, as a build before this one would have.
    EXPECT_FALSE(connection.Exec(insert + "('v', 'ops', 'viewer', x'03', 4, NULL)").ok());
  }
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteTokenStore(path));
  ASSERT_OK_AND_ASSIGN(std::vector<TokenRecord> kept, store->ListTokens());
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].name, "old-robot");
  EXPECT_EQ(kept[0].role, TokenRole::kRobot);
  EXPECT_EQ(kept[1].name, "old-admin");
  EXPECT_EQ(kept[1].role, TokenRole::kAdmin);
  EXPECT_EQ(kept[1].revoked_at, 3);
  ASSERT_OK_AND_ASSIGN(CreatedToken viewer,
                       store->CreateToken("screen", "ops", TokenRole::kViewer, std::nullopt));
  ASSERT_OK_AND_ASSIGN(TokenRecord got, store->Authenticate(viewer.secret, kNow));
  EXPECT_EQ(got.role, TokenRole::kViewer);
  ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(path));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, CurrentSchemaVersion());
}

TEST_P(TokenStoreTest, SchemaRejectsAnUnknownRole) {
  // The CHECK constraint guards the database against writers other than this store.
  const std::string hash = GetParam() == Backend::kSqlite ? "x'00'" : "'\\x00'::bytea";
  const std::string insert =
      "INSERT INTO tokens (name, robot_id, role, secret_hash, created_at) VALUES ('x', 'r', ";
  EXPECT_FALSE(database_.Exec(absl::StrCat(insert, "'root', ", hash, ", 1)")).ok());
  EXPECT_OK(database_.Exec(absl::StrCat(insert, "'robot', ", hash, ", 1)")));
  EXPECT_OK(database_.Exec(absl::StrCat("INSERT INTO tokens (name, robot_id, role, secret_hash, "
                                        "created_at) VALUES ('v', 'r', 'viewer', ",
                                        GetParam() == Backend::kSqlite ? "x'01'" : "'\\x01'::bytea",
                                        ", 1)")));
}

}  // namespace
}  // namespace waymark::storage
