// CrossingStore on SQLite: one connection behind a mutex, one transaction per mutating call.

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "storage/crossing_records.h"
#include "storage/crossing_store.h"
#include "storage/migrations.h"
#include "storage/sqlite.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"

namespace waymark::storage {
namespace {

using sqlite::Connection;
using sqlite::Statement;
using sqlite::StepResult;
using sqlite::Transaction;
using sqlite::UniqueViolation;

// Checks that a stored blob holds exactly `expected` bytes.
absl::Status CheckBlobSize(const Statement& row, int column, int64_t expected, int64_t view_id,
                           const char* what) {
  return CheckStoredBlobSize(static_cast<int64_t>(row.ColumnBlobView(column).size()), expected,
                             view_id, what);
}

// Columns read by ReadViewRow, in order.
constexpr char kSelectViews[] =
    "SELECT v.id, v.crossing_id, v.heading_deg, v.width, v.height, v.keypoint_count, "
    "v.keypoints, v.descriptors, v.hue_hist, v.hue_bins, v.format_version, v.content_sha256, "
    "v.position, v.global_code, v.global_sample, v.heading_known FROM view v JOIN crossing c ON "
    "c.id = v.crossing_id WHERE c.db_id = ? AND v.id > ? ORDER BY v.id";

// NULL for an empty string: the blob columns that may be absent use NULL for "none".
absl::Status BindOptionalBlob(Statement& statement, int index, const std::string& bytes) {
  return bytes.empty() ? statement.BindNull(index)
                       : statement.BindBlob(index, bytes.data(), bytes.size());
}

absl::StatusOr<ViewRecord> ReadViewRow(const Statement& row) {
  ViewRecord view;
  view.id = row.ColumnInt64(0);
  view.crossing_id = row.ColumnInt64(1);
  view.heading_deg = row.ColumnDouble(2);
  view.width = row.ColumnInt32(3);
  view.height = row.ColumnInt32(4);
  view.keypoint_count = row.ColumnInt32(5);
  const int64_t hue_bins = row.ColumnInt64(9);
  view.format_version = row.ColumnInt32(10);
  if (view.keypoint_count < 0 || hue_bins < 0) {
    return absl::DataLossError(absl::StrCat("view ", view.id, ": negative stored count"));
  }
  const int64_t count = view.keypoint_count;
  RETURN_IF_ERROR(CheckBlobSize(row, 6, count * kKeypointFloats * 4, view.id, "keypoints"));
  RETURN_IF_ERROR(CheckBlobSize(row, 7, count * kDescriptorBytes, view.id, "descriptors"));
  RETURN_IF_ERROR(CheckBlobSize(row, 8, hue_bins * 4, view.id, "hue histogram"));
  ASSIGN_OR_RETURN(view.keypoints, row.ColumnFloatBlob(6));
  view.descriptors = row.ColumnBlob(7);
  ASSIGN_OR_RETURN(view.hue_hist, row.ColumnFloatBlob(8));
  if (!row.ColumnIsNull(11)) view.content_sha256 = std::string(row.ColumnBlobView(11));
  view.position = row.ColumnText(12);
  if (!row.ColumnIsNull(13)) view.global_code = std::string(row.ColumnBlobView(13));
  if (!row.ColumnIsNull(14)) view.global_sample = std::string(row.ColumnBlobView(14));
  view.heading_known = row.ColumnInt32(15) != 0;
  return view;
}

class SqliteCrossingStore final : public CrossingStore {
 public:
  explicit SqliteCrossingStore(Connection connection) : connection_(std::move(connection)) {}

  // One server per file (storage/database_lock.h): nobody else writes, nothing to watch.
  bool shared() const override { return false; }
  absl::StatusOr<std::unique_ptr<DatabaseWriteLock>> LockForWriting(int64_t) override {
    return std::make_unique<DatabaseWriteLock>();
  }
  absl::StatusOr<std::unique_ptr<ChangeFeed>> WatchChanges() override {
    return std::unique_ptr<ChangeFeed>();
  }

  absl::StatusOr<DatabaseRecord> CreateDatabase(const std::string& name,
                                                const std::string& params) override {
    if (name.empty()) return absl::InvalidArgumentError("database name is empty");
    std::lock_guard<std::mutex> lock(mutex_);
    DatabaseRecord record;
    record.name = name;
    record.params = params;
    record.created_at = NowSeconds();
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO crossing_db (name, params, created_at) "
                                         "VALUES (?, ?, ?)"));
    RETURN_IF_ERROR(insert.BindText(1, name));
    RETURN_IF_ERROR(insert.BindText(2, params));
    RETURN_IF_ERROR(insert.BindDouble(3, record.created_at));
    RETURN_IF_ERROR(NameTaken(insert.Run(UniqueViolation::kAlreadyExists),
                              absl::StrCat("database ", Quoted(name))));
    record.id = connection_.LastInsertRowId();
    return record;
  }

  absl::StatusOr<std::vector<DatabaseRecord>> ListDatabases() override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT id, name, params, created_at, revision, reload_revision FROM crossing_db "
                                         "ORDER BY name"));
    std::vector<DatabaseRecord> records;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, select.Step());
      if (step == StepResult::kDone) break;
      records.push_back(ReadDatabaseRow(select));
    }
    return records;
  }

  absl::StatusOr<DatabaseRecord> GetDatabase(const std::string& name) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT id, name, params, created_at, revision, reload_revision FROM crossing_db "
                                         "WHERE name = ?"));
    RETURN_IF_ERROR(select.BindText(1, name));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) {
      return absl::NotFoundError(absl::StrCat("database ", Quoted(name), " not found"));
    }
    return ReadDatabaseRow(select);
  }

  absl::Status UpdateDatabaseParams(int64_t database_id, const std::string& params) override {
    std::lock_guard<std::mutex> lock(mutex_);
    // One statement: atomic on its own, no explicit transaction needed.
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE crossing_db SET params = ?, revision = revision + 1, "
                                         "reload_revision = reload_revision + 1 WHERE id = ?"));
    RETURN_IF_ERROR(update.BindText(1, params));
    RETURN_IF_ERROR(update.BindInt64(2, database_id));
    RETURN_IF_ERROR(update.Run());
    if (connection_.Changes() == 0) return DatabaseNotFound(database_id);
    return absl::OkStatus();
  }

  absl::Status DeleteDatabase(const std::string& name) override {
    std::lock_guard<std::mutex> lock(mutex_);
    // ON DELETE CASCADE removes crossings, their views, clusters and memberships within this one
    // statement, so it is atomic without an explicit transaction.
    ASSIGN_OR_RETURN(Statement remove,
                     connection_.Prepare("DELETE FROM crossing_db WHERE name = ?"));
    RETURN_IF_ERROR(remove.BindText(1, name));
    RETURN_IF_ERROR(remove.Run());
    if (connection_.Changes() == 0) {
      return absl::NotFoundError(absl::StrCat("database ", Quoted(name), " not found"));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<CrossingRecord> AddCrossing(int64_t database_id, const std::string& name,
                                             const std::string& label) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(CrossingRecord record, AddCrossingLocked({database_id, name, label}));
    RETURN_IF_ERROR(BumpRevisionLocked(database_id, /*reload=*/false));
    RETURN_IF_ERROR(txn.Commit());
    return record;
  }

  absl::StatusOr<std::vector<CrossingRecord>> ListCrossings(int64_t database_id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    RETURN_IF_ERROR(DatabaseNameLocked(database_id).status());
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT id, db_id, name, label FROM crossing "
                                         "WHERE db_id = ? ORDER BY id"));
    RETURN_IF_ERROR(select.BindInt64(1, database_id));
    std::vector<CrossingRecord> records;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, select.Step());
      if (step == StepResult::kDone) break;
      CrossingRecord record;
      record.id = select.ColumnInt64(0);
      record.database_id = select.ColumnInt64(1);
      record.name = select.ColumnText(2);
      record.label = select.ColumnText(3);
      records.push_back(std::move(record));
    }
    return records;
  }

  absl::StatusOr<int> DeleteCrossing(int64_t database_id, int64_t crossing_id,
                                     const std::vector<ClusterRecord>& clusters) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(std::string db_name, DatabaseNameLocked(database_id));
    ASSIGN_OR_RETURN(int64_t crossing_db, CrossingDatabaseLocked(crossing_id));
    if (crossing_db != database_id) {
      return absl::NotFoundError(
          absl::StrCat("crossing ", crossing_id, " not found in database ", Quoted(db_name)));
    }
    ASSIGN_OR_RETURN(Statement count,
                     connection_.Prepare("SELECT COUNT(*) FROM view WHERE crossing_id = ?"));
    RETURN_IF_ERROR(count.BindInt64(1, crossing_id));
    RETURN_IF_ERROR(count.Step().status());
    const int deleted_views = static_cast<int>(count.ColumnInt64(0));

    // Clusters first: the new ones are validated against the views that remain.
    RETURN_IF_ERROR(DeleteClustersLocked(database_id));
    ASSIGN_OR_RETURN(Statement remove, connection_.Prepare("DELETE FROM crossing WHERE id = ?"));
    RETURN_IF_ERROR(remove.BindInt64(1, crossing_id));
    RETURN_IF_ERROR(remove.Run());  // cascades to the views and their memberships
    RETURN_IF_ERROR(InsertClustersLocked(database_id, clusters).status());
    RETURN_IF_ERROR(BumpRevisionLocked(database_id, /*reload=*/true));
    RETURN_IF_ERROR(txn.Commit());
    return deleted_views;
  }

  absl::StatusOr<AddViewResult> AddView(const ViewRecord& view,
                                        const ClusterAssignment& assignment) override {
    RETURN_IF_ERROR(ValidateView(view));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(int64_t database_id, CrossingDatabaseLocked(view.crossing_id));
    ASSIGN_OR_RETURN(AddViewResult result, AddViewLocked(database_id, view, assignment));
    RETURN_IF_ERROR(BumpRevisionLocked(database_id, /*reload=*/false));
    RETURN_IF_ERROR(txn.Commit());
    return result;
  }

  absl::StatusOr<AddViewResult> AddViewWithNewCrossing(
      const NewCrossing& crossing, const ViewRecord& view,
      const ClusterAssignment& assignment) override {
    RETURN_IF_ERROR(ValidateView(view));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(CrossingRecord created, AddCrossingLocked(crossing));
    ViewRecord with_crossing = view;
    with_crossing.crossing_id = created.id;
    ASSIGN_OR_RETURN(AddViewResult result,
                     AddViewLocked(crossing.database_id, with_crossing, assignment));
    RETURN_IF_ERROR(BumpRevisionLocked(crossing.database_id, /*reload=*/false));
    RETURN_IF_ERROR(txn.Commit());
    return result;
  }

  absl::StatusOr<ViewReplacementResult> ReplaceViews(const ViewReplacement& replacement) override {
    RETURN_IF_ERROR(ValidateReplacement(replacement));
    const int64_t database_id = replacement.database_id;
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(std::string db_name, DatabaseNameLocked(database_id));
    // Clusters first (a deleted centre would take its cluster row along by cascade anyway).
    RETURN_IF_ERROR(DeleteClustersLocked(database_id));
    for (int64_t view_id : replacement.replaced_view_ids) {
      RETURN_IF_ERROR(DeleteViewLocked(database_id, db_name, view_id));
    }
    ViewReplacementResult result;
    ASSIGN_OR_RETURN(result.clusters, InsertClustersLocked(database_id, replacement.clusters));
    ViewRecord view = replacement.view;
    if (replacement.create_crossing) {
      ASSIGN_OR_RETURN(CrossingRecord created,
                       AddCrossingLocked({database_id, replacement.crossing_name, ""}));
      view.crossing_id = created.id;
    } else {
      ASSIGN_OR_RETURN(int64_t crossing_db, CrossingDatabaseLocked(view.crossing_id));
      if (crossing_db != database_id) {
        return absl::NotFoundError(absl::StrCat("crossing ", view.crossing_id,
                                                " not found in database ", Quoted(db_name)));
      }
    }
    ClusterAssignment assignment;
    if (replacement.join_cluster >= 0) {
      assignment.new_cluster = false;
      assignment.cluster_id = result.clusters[replacement.join_cluster].id;
    }
    ASSIGN_OR_RETURN(result.added, AddViewLocked(database_id, view, assignment));
    RETURN_IF_ERROR(BumpRevisionLocked(database_id, /*reload=*/true));
    RETURN_IF_ERROR(txn.Commit());
    return result;
  }

  absl::Status ForEachViewAfter(int64_t database_id, int64_t after_view_id,
                                const std::function<absl::Status(ViewRecord&&)>& visit) override {
    std::lock_guard<std::mutex> lock(mutex_);
    RETURN_IF_ERROR(DatabaseNameLocked(database_id).status());
    ASSIGN_OR_RETURN(Statement select, connection_.Prepare(kSelectViews));
    RETURN_IF_ERROR(select.BindInt64(1, database_id));
    RETURN_IF_ERROR(select.BindInt64(2, after_view_id));
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, select.Step());
      if (step == StepResult::kDone) break;
      ASSIGN_OR_RETURN(ViewRecord view, ReadViewRow(select));
      RETURN_IF_ERROR(visit(std::move(view)));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<std::string> LoadViewImage(int64_t view_id) override {
    return LoadViewBlob(view_id, "image", "stored image");
  }

  absl::StatusOr<std::vector<ClusterRecord>> LoadClusters(int64_t database_id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    RETURN_IF_ERROR(DatabaseNameLocked(database_id).status());
    // LEFT JOIN so that a cluster without members (never written by this code) still shows up.
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT c.id, c.center_view_id, m.view_id FROM cluster c "
                                         "LEFT JOIN cluster_member m ON m.cluster_id = c.id "
                                         "WHERE c.db_id = ? ORDER BY c.id, m.view_id"));
    RETURN_IF_ERROR(select.BindInt64(1, database_id));
    std::vector<ClusterRecord> clusters;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, select.Step());
      if (step == StepResult::kDone) break;
      const int64_t cluster_id = select.ColumnInt64(0);
      if (clusters.empty() || clusters.back().id != cluster_id) {
        ClusterRecord cluster;
        cluster.id = cluster_id;
        cluster.center_view_id = select.ColumnInt64(1);
        clusters.push_back(std::move(cluster));
      }
      if (!select.ColumnIsNull(2)) clusters.back().member_view_ids.push_back(select.ColumnInt64(2));
    }
    return clusters;
  }

  absl::Status SaveVocabulary(const VocabularyRecord& vocabulary,
                              const std::vector<ViewCode>& codes) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    RETURN_IF_ERROR(DatabaseNameLocked(vocabulary.database_id).status());
    RETURN_IF_ERROR(UpdateCodesLocked(vocabulary.database_id, codes));
    ASSIGN_OR_RETURN(Statement upsert,
                     connection_.Prepare("INSERT OR REPLACE INTO crossing_vocabulary (db_id, "
                                         "trained_views, data, updated_at) VALUES (?, ?, ?, ?)"));
    RETURN_IF_ERROR(upsert.BindInt64(1, vocabulary.database_id));
    RETURN_IF_ERROR(upsert.BindInt64(2, vocabulary.trained_views));
    RETURN_IF_ERROR(upsert.BindBlob(3, vocabulary.data.data(), vocabulary.data.size()));
    RETURN_IF_ERROR(upsert.BindDouble(4, NowSeconds()));
    RETURN_IF_ERROR(upsert.Run());
    RETURN_IF_ERROR(BumpRevisionLocked(vocabulary.database_id, /*reload=*/true));
    return txn.Commit();
  }

  absl::Status SaveViewCodes(int64_t database_id, const std::vector<ViewCode>& codes) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    RETURN_IF_ERROR(DatabaseNameLocked(database_id).status());
    RETURN_IF_ERROR(UpdateCodesLocked(database_id, codes));
    RETURN_IF_ERROR(BumpRevisionLocked(database_id, /*reload=*/true));
    return txn.Commit();
  }

  absl::StatusOr<std::string> LoadWorkImage(int64_t view_id) override {
    return LoadViewBlob(view_id, "work_image", "working image");
  }

  absl::StatusOr<std::optional<VocabularyRecord>> LoadVocabulary(int64_t database_id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT trained_views, data FROM crossing_vocabulary "
                                         "WHERE db_id = ?"));
    RETURN_IF_ERROR(select.BindInt64(1, database_id));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step != StepResult::kRow) return std::optional<VocabularyRecord>();
    VocabularyRecord record;
    record.database_id = database_id;
    record.trained_views = select.ColumnInt32(0);
    record.data = std::string(select.ColumnBlobView(1));
    return std::optional<VocabularyRecord>(std::move(record));
  }

  absl::StatusOr<std::vector<ClusterRecord>> ReplaceClusters(
      int64_t database_id, const std::vector<ClusterRecord>& clusters) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    RETURN_IF_ERROR(DatabaseNameLocked(database_id).status());
    RETURN_IF_ERROR(DeleteClustersLocked(database_id));
    ASSIGN_OR_RETURN(std::vector<ClusterRecord> inserted,
                     InsertClustersLocked(database_id, clusters));
    RETURN_IF_ERROR(BumpRevisionLocked(database_id, /*reload=*/true));
    RETURN_IF_ERROR(txn.Commit());
    return inserted;
  }

 private:
  // Helpers named *Locked run with mutex_ held, inside the caller's transaction if it has one.

  static DatabaseRecord ReadDatabaseRow(const Statement& row) {
    DatabaseRecord record;
    record.id = row.ColumnInt64(0);
    record.name = row.ColumnText(1);
    record.params = row.ColumnText(2);
    record.created_at = row.ColumnDouble(3);
    record.revision = row.ColumnInt64(4);
    record.reload_revision = row.ColumnInt64(5);
    return record;
  }

  // Adds a write to the database's revisions (DatabaseRecord), inside the caller's transaction.
  absl::Status BumpRevisionLocked(int64_t database_id, bool reload) {
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE crossing_db SET revision = revision + 1, "
                                         "reload_revision = reload_revision + ? WHERE id = ?"));
    RETURN_IF_ERROR(update.BindInt64(1, reload ? 1 : 0));
    RETURN_IF_ERROR(update.BindInt64(2, database_id));
    return update.Run();
  }

  // The database's name (for messages), NOT_FOUND when the id is unknown.
  absl::StatusOr<std::string> DatabaseNameLocked(int64_t database_id) {
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT name FROM crossing_db WHERE id = ?"));
    RETURN_IF_ERROR(select.BindInt64(1, database_id));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) return DatabaseNotFound(database_id);
    return select.ColumnText(0);
  }

  // The database a crossing belongs to, NOT_FOUND when the crossing is unknown.
  absl::StatusOr<int64_t> CrossingDatabaseLocked(int64_t crossing_id) {
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT db_id FROM crossing WHERE id = ?"));
    RETURN_IF_ERROR(select.BindInt64(1, crossing_id));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) {
      return absl::NotFoundError(absl::StrCat("crossing ", crossing_id, " not found"));
    }
    return select.ColumnInt64(0);
  }

  // The database a cluster belongs to, NOT_FOUND when the cluster is unknown.
  absl::StatusOr<int64_t> ClusterDatabaseLocked(int64_t cluster_id) {
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT db_id FROM cluster WHERE id = ?"));
    RETURN_IF_ERROR(select.BindInt64(1, cluster_id));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) {
      return absl::NotFoundError(absl::StrCat("cluster ", cluster_id, " not found"));
    }
    return select.ColumnInt64(0);
  }

  absl::StatusOr<CrossingRecord> AddCrossingLocked(const NewCrossing& crossing) {
    if (crossing.name.empty()) return absl::InvalidArgumentError("crossing name is empty");
    ASSIGN_OR_RETURN(std::string db_name, DatabaseNameLocked(crossing.database_id));
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO crossing (db_id, name, label) "
                                         "VALUES (?, ?, ?)"));
    RETURN_IF_ERROR(insert.BindInt64(1, crossing.database_id));
    RETURN_IF_ERROR(insert.BindText(2, crossing.name));
    RETURN_IF_ERROR(insert.BindText(3, crossing.label));
    RETURN_IF_ERROR(NameTaken(
        insert.Run(UniqueViolation::kAlreadyExists),
        absl::StrCat("crossing ", Quoted(crossing.name), " in database ", Quoted(db_name))));
    CrossingRecord record;
    record.id = connection_.LastInsertRowId();
    record.database_id = crossing.database_id;
    record.name = crossing.name;
    record.label = crossing.label;
    return record;
  }

  // Deletes a view of the database (its memberships go by cascade).
  absl::Status DeleteViewLocked(int64_t database_id, const std::string& db_name, int64_t view_id) {
    ASSIGN_OR_RETURN(Statement remove,
                     connection_.Prepare("DELETE FROM view WHERE id = ? AND crossing_id IN "
                                         "(SELECT id FROM crossing WHERE db_id = ?)"));
    RETURN_IF_ERROR(remove.BindInt64(1, view_id));
    RETURN_IF_ERROR(remove.BindInt64(2, database_id));
    RETURN_IF_ERROR(remove.Run());
    if (connection_.Changes() == 0) {
      return absl::NotFoundError(
          absl::StrCat("view ", view_id, " not found in database ", Quoted(db_name)));
    }
    return absl::OkStatus();
  }

  // ALREADY_EXISTS naming the view of the database that already holds `content_sha256`.
  absl::Status CheckNewContentLocked(int64_t database_id, const std::string& content_sha256) {
    if (content_sha256.empty()) return absl::OkStatus();  // unknown content: nothing to compare
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT v.id FROM view v JOIN crossing c "
                                         "ON c.id = v.crossing_id "
                                         "WHERE c.db_id = ? AND v.content_sha256 = ? LIMIT 1"));
    RETURN_IF_ERROR(select.BindInt64(1, database_id));
    RETURN_IF_ERROR(select.BindBlob(2, content_sha256.data(), content_sha256.size()));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) return absl::OkStatus();
    return DuplicateImage(select.ColumnInt64(0), content_sha256);
  }

  // One blob column of a view (`column` is ours, never a client's); NOT_FOUND for an unknown
  // view or a NULL blob (`what` names it in the message).
  absl::StatusOr<std::string> LoadViewBlob(int64_t view_id, const char* column, const char* what) {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement select, connection_.Prepare(absl::StrCat(
                                           "SELECT ", column, " FROM view WHERE id = ?")));
    RETURN_IF_ERROR(select.BindInt64(1, view_id));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) return ViewNotFound(view_id);
    if (select.ColumnIsNull(0)) {
      return absl::NotFoundError(absl::StrCat("view ", view_id, " has no ", what));
    }
    return std::string(select.ColumnBlobView(0));
  }

  // Sets the codes of those views that still belong to `database_id` (within the caller's
  // transaction).
  absl::Status UpdateCodesLocked(int64_t database_id, const std::vector<ViewCode>& codes) {
    if (codes.empty()) return absl::OkStatus();
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE view SET global_code = ? WHERE id = ? AND "
                                         "crossing_id IN (SELECT id FROM crossing WHERE db_id = ?)"));
    for (const ViewCode& c : codes) {
      update.Reset();
      RETURN_IF_ERROR(BindOptionalBlob(update, 1, c.code));
      RETURN_IF_ERROR(update.BindInt64(2, c.view_id));
      RETURN_IF_ERROR(update.BindInt64(3, database_id));
      RETURN_IF_ERROR(update.Run());
    }
    return absl::OkStatus();
  }

  // Inserts a validated view of `database_id` and its cluster membership, unless another view of
  // the database holds the same image (ALREADY_EXISTS).
  absl::StatusOr<AddViewResult> AddViewLocked(int64_t database_id, const ViewRecord& view,
                                              const ClusterAssignment& assignment) {
    RETURN_IF_ERROR(CheckNewContentLocked(database_id, view.content_sha256));
    ASSIGN_OR_RETURN(
        Statement insert,
        connection_.Prepare(
            "INSERT INTO view (crossing_id, heading_deg, width, height, keypoint_count, "
            "keypoints, descriptors, hue_hist, hue_bins, format_version, image, created_at, "
            "content_sha256, position, work_image, global_code, global_sample, heading_known) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"));
    RETURN_IF_ERROR(insert.BindInt64(1, view.crossing_id));
    RETURN_IF_ERROR(insert.BindDouble(2, view.heading_deg));
    RETURN_IF_ERROR(insert.BindInt64(3, view.width));
    RETURN_IF_ERROR(insert.BindInt64(4, view.height));
    RETURN_IF_ERROR(insert.BindInt64(5, view.keypoint_count));
    RETURN_IF_ERROR(insert.BindBlob(6, view.keypoints));
    RETURN_IF_ERROR(insert.BindBlob(7, view.descriptors));
    RETURN_IF_ERROR(insert.BindBlob(8, view.hue_hist));
    RETURN_IF_ERROR(insert.BindInt64(9, static_cast<int64_t>(view.hue_hist.size())));
    RETURN_IF_ERROR(insert.BindInt64(10, view.format_version));
    // NULL, not an empty blob, marks "image not stored" (LoadViewImage answers NOT_FOUND).
    RETURN_IF_ERROR(view.image.empty() ? insert.BindNull(11)
                                       : insert.BindBlob(11, view.image.data(), view.image.size()));
    RETURN_IF_ERROR(insert.BindDouble(12, NowSeconds()));
    RETURN_IF_ERROR(view.content_sha256.empty()
                        ? insert.BindNull(13)
                        : insert.BindBlob(13, view.content_sha256.data(),
                                          view.content_sha256.size()));
    RETURN_IF_ERROR(insert.BindText(14, view.position));
    RETURN_IF_ERROR(BindOptionalBlob(insert, 15, view.work_image));
    RETURN_IF_ERROR(BindOptionalBlob(insert, 16, view.global_code));
    RETURN_IF_ERROR(BindOptionalBlob(insert, 17, view.global_sample));
    RETURN_IF_ERROR(insert.BindInt64(18, view.heading_known ? 1 : 0));
    RETURN_IF_ERROR(insert.Run());

    AddViewResult result;
    result.view_id = connection_.LastInsertRowId();
    result.crossing_id = view.crossing_id;
    if (assignment.new_cluster) {
      ASSIGN_OR_RETURN(result.cluster_id, InsertClusterRowLocked(database_id, result.view_id));
    } else {
      ASSIGN_OR_RETURN(int64_t cluster_db, ClusterDatabaseLocked(assignment.cluster_id));
      if (cluster_db != database_id) {
        return absl::InvalidArgumentError(
            absl::StrCat("cluster ", assignment.cluster_id, " belongs to database ", cluster_db,
                         ", but crossing ", view.crossing_id, " to database ", database_id));
      }
      result.cluster_id = assignment.cluster_id;
    }
    RETURN_IF_ERROR(InsertMemberLocked(result.cluster_id, result.view_id));
    return result;
  }

  absl::Status DeleteClustersLocked(int64_t database_id) {
    ASSIGN_OR_RETURN(Statement remove, connection_.Prepare("DELETE FROM cluster WHERE db_id = ?"));
    RETURN_IF_ERROR(remove.BindInt64(1, database_id));
    return remove.Run();  // memberships go by cascade
  }

  absl::StatusOr<int64_t> InsertClusterRowLocked(int64_t database_id, int64_t center_view_id) {
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO cluster (db_id, center_view_id) "
                                         "VALUES (?, ?)"));
    RETURN_IF_ERROR(insert.BindInt64(1, database_id));
    RETURN_IF_ERROR(insert.BindInt64(2, center_view_id));
    RETURN_IF_ERROR(insert.Run());
    return connection_.LastInsertRowId();
  }

  absl::Status InsertMemberLocked(int64_t cluster_id, int64_t view_id) {
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO cluster_member (cluster_id, view_id) "
                                         "VALUES (?, ?)"));
    RETURN_IF_ERROR(insert.BindInt64(1, cluster_id));
    RETURN_IF_ERROR(insert.BindInt64(2, view_id));
    return insert.Run();
  }

  // Inserts `clusters` for the database after checking that each one is well formed (centre among
  // its members, no duplicate member) and that every view exists and belongs to the database.
  // Returns them in the given order with their new ids.
  absl::StatusOr<std::vector<ClusterRecord>> InsertClustersLocked(
      int64_t database_id, const std::vector<ClusterRecord>& clusters) {
    // One lookup statement reused for every view: clusters cover the whole database.
    ASSIGN_OR_RETURN(Statement view_db,
                     connection_.Prepare("SELECT c.db_id FROM view v "
                                         "JOIN crossing c ON c.id = v.crossing_id WHERE v.id = ?"));
    std::vector<ClusterRecord> inserted;
    inserted.reserve(clusters.size());
    for (size_t i = 0; i < clusters.size(); ++i) {
      const ClusterRecord& cluster = clusters[i];
      RETURN_IF_ERROR(CheckClusterShape(cluster, i));
      const std::string where = ClusterName(cluster, i);
      for (int64_t view_id : cluster.member_view_ids) {
        view_db.Reset();
        RETURN_IF_ERROR(view_db.BindInt64(1, view_id));
        ASSIGN_OR_RETURN(StepResult step, view_db.Step());
        if (step == StepResult::kDone) {
          return absl::NotFoundError(absl::StrCat(where, ": view ", view_id, " not found"));
        }
        if (view_db.ColumnInt64(0) != database_id) {
          return absl::InvalidArgumentError(absl::StrCat(
              where, ": view ", view_id, " belongs to another database than ", database_id));
        }
      }
      ClusterRecord record = cluster;
      ASSIGN_OR_RETURN(record.id, InsertClusterRowLocked(database_id, cluster.center_view_id));
      for (int64_t view_id : cluster.member_view_ids) {
        RETURN_IF_ERROR(InsertMemberLocked(record.id, view_id));
      }
      inserted.push_back(std::move(record));
    }
    return inserted;
  }

  std::mutex mutex_;  // one connection, used by one thread at a time
  Connection connection_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<CrossingStore>> OpenSqliteCrossingStore(const std::string& path) {
  ASSIGN_OR_RETURN(Connection connection, OpenMigratedDatabase(path));
  return std::unique_ptr<CrossingStore>(new SqliteCrossingStore(std::move(connection)));
}

}  // namespace waymark::storage
