// user_version migrations: fresh files, upgrades, idempotence, a failing step, a newer file.

#include "storage/migrations.h"

#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using sqlite::Connection;
using sqlite::Statement;
using ::waymark::storage::testing::TempDir;

bool TableExists(Connection& connection, const std::string& table) {
  absl::StatusOr<Statement> stmt =
      connection.Prepare("SELECT 1 FROM sqlite_schema WHERE type = 'table' AND name = ?");
  if (!stmt.ok() || !stmt->BindText(1, table).ok()) return false;
  absl::StatusOr<sqlite::StepResult> step = stmt->Step();
  return step.ok() && *step == sqlite::StepResult::kRow;
}

// CREATE TABLE fails when run twice, so these steps also detect a step applied again.
const std::vector<absl::string_view> kTwoSteps = {
    "CREATE TABLE a (x INTEGER)",
    "CREATE TABLE b (y INTEGER); CREATE INDEX b_y ON b(y)",
};

TEST(MigrationsTest, FreshFileGetsEveryStepAndTheLatestVersion) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK_AND_ASSIGN(int before, ReadSchemaVersion(connection));
  EXPECT_EQ(before, 0);
  ASSERT_OK(ApplyMigrations(connection, kTwoSteps));
  ASSERT_OK_AND_ASSIGN(int after, ReadSchemaVersion(connection));
  EXPECT_EQ(after, 2);
  EXPECT_TRUE(TableExists(connection, "a"));
  EXPECT_TRUE(TableExists(connection, "b"));
}

TEST(MigrationsTest, RerunningIsANoOp) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(ApplyMigrations(connection, kTwoSteps));
  ASSERT_OK(ApplyMigrations(connection, kTwoSteps));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, 2);
}

TEST(MigrationsTest, OlderFileRunsOnlyTheMissingSteps) {
  TempDir dir;
  {
    ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(dir.File("m.db")));
    ASSERT_OK(ApplyMigrations(connection, {kTwoSteps[0]}));  // an older build
  }
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(dir.File("m.db")));
  ASSERT_OK(ApplyMigrations(connection, kTwoSteps));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, 2);
  EXPECT_TRUE(TableExists(connection, "b"));
}

TEST(MigrationsTest, FailingStepIsRolledBackAndEarlierStepsStay) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  const std::vector<absl::string_view> steps = {
      kTwoSteps[0],
      "CREATE TABLE c (z INTEGER); INSERT INTO missing VALUES (1)",
  };
  absl::Status status = ApplyMigrations(connection, steps);
  EXPECT_EQ(status.code(), absl::StatusCode::kInternal);
  EXPECT_NE(status.message().find("migration to version 2"), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find("no such table: missing"), absl::string_view::npos) << status;

  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, 1);
  EXPECT_TRUE(TableExists(connection, "a"));
  EXPECT_FALSE(TableExists(connection, "c"));  // the half-applied step left nothing
  EXPECT_TRUE(connection.AutoCommit());
}

TEST(MigrationsTest, FileFromNewerBuildIsRefused) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("PRAGMA user_version = 7"));
  absl::Status status = ApplyMigrations(connection, kTwoSteps);
  EXPECT_EQ(status.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(status.message().find("schema version 7"), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find("up to 2"), absl::string_view::npos) << status;
  EXPECT_FALSE(TableExists(connection, "a"));

  EXPECT_EQ(ApplyMigrations(connection, {}).code(), absl::StatusCode::kFailedPrecondition);
}

TEST(MigrationsTest, WaymarkSchemaCreatesTheCrossingTables) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(MigrateSchema(connection));
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, CurrentSchemaVersion());
  EXPECT_GE(CurrentSchemaVersion(), 1);
  for (const char* table : {"crossing_db", "crossing", "view", "cluster", "cluster_member"}) {
    EXPECT_TRUE(TableExists(connection, table)) << table;
  }
  // AUTOINCREMENT tables are tracked in sqlite_sequence; its presence shows the keyword took.
  EXPECT_TRUE(TableExists(connection, "sqlite_sequence"));
  // Every foreign key cascades: deleting a database must not be blocked by its children.
  ASSERT_OK_AND_ASSIGN(
      Statement fks,
      connection.Prepare("SELECT m.name, f.\"table\", f.on_delete FROM sqlite_schema m, "
                         "pragma_foreign_key_list(m.name) f WHERE m.type = 'table' "
                         "AND m.name NOT LIKE 'slam\\_%' ESCAPE '\\'"));
  int fk_count = 0;
  while (true) {
    ASSERT_OK_AND_ASSIGN(sqlite::StepResult step, fks.Step());
    if (step == sqlite::StepResult::kDone) break;
    ++fk_count;
    EXPECT_EQ(fks.ColumnText(2), "CASCADE") << fks.ColumnText(0) << " -> " << fks.ColumnText(1);
  }
  EXPECT_EQ(fk_count, 7);  // crossing, view, cluster x2, cluster_member x2, crossing_vocabulary
}

}  // namespace
}  // namespace waymark::storage
