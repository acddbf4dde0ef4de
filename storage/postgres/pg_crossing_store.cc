// CrossingStore on PostgreSQL (issue 19): the SQLite store's records, transactions and errors, for
// several servers on one database.
//
// Writes to one crossing database are serialised by a transaction-scoped advisory lock on the
// database's id (LockDatabase), taken before anything is read: the duplicate-image check and the
// insert are then atomic across servers, as SQLite's single writer made them, and view ids (one
// sequence) increase in commit order within a database, so they remain its enrollment order.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "storage/crossing_records.h"
#include "storage/crossing_store.h"
#include "storage/postgres/pg.h"
#include "storage/postgres/pg_coordination.h"
#include "storage/postgres/pg_schema.h"
#include "storage/postgres/pg_stores.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"

namespace waymark::storage {
namespace {

using pg::Connection;
using pg::Params;
using pg::Result;
using pg::UniqueViolation;

// Views read per round trip by ForEachView: a server loading thousands of views never holds more
// than this many rows (a view's descriptors are tens of kilobytes).
constexpr int kViewPage = 64;

// Columns read by ReadViewRow, in order.
constexpr char kSelectViewPage[] =
    "SELECT v.id, v.crossing_id, v.heading_deg, v.width, v.height, v.keypoint_count, "
    "v.keypoints, v.descriptors, v.hue_hist, v.hue_bins, v.format_version, v.content_sha256, "
    "v.position, v.global_code, v.global_sample, v.heading_known FROM view v JOIN crossing c ON "
    "c.id = v.crossing_id WHERE c.db_id = $1 AND v.id > $2 ORDER BY v.id LIMIT $3";

absl::StatusOr<ViewRecord> ReadViewRow(const Result& rows, int r) {
  ViewRecord view;
  view.id = rows.Int64(r, 0);
  view.crossing_id = rows.Int64(r, 1);
  view.heading_deg = rows.Double(r, 2);
  view.width = rows.Int32(r, 3);
  view.height = rows.Int32(r, 4);
  view.keypoint_count = rows.Int32(r, 5);
  const int64_t hue_bins = rows.Int64(r, 9);
  view.format_version = rows.Int32(r, 10);
  if (view.keypoint_count < 0 || hue_bins < 0) {
    return absl::DataLossError(absl::StrCat("view ", view.id, ": negative stored count"));
  }
  const int64_t count = view.keypoint_count;
  const auto size = [&](int column) { return static_cast<int64_t>(rows.Bytes(r, column).size()); };
  RETURN_IF_ERROR(CheckStoredBlobSize(size(6), count * kKeypointFloats * 4, view.id, "keypoints"));
  RETURN_IF_ERROR(CheckStoredBlobSize(size(7), count * kDescriptorBytes, view.id, "descriptors"));
  RETURN_IF_ERROR(CheckStoredBlobSize(size(8), hue_bins * 4, view.id, "hue histogram"));
  ASSIGN_OR_RETURN(view.keypoints, rows.Floats(r, 6));
  view.descriptors = rows.ByteVector(r, 7);
  ASSIGN_OR_RETURN(view.hue_hist, rows.Floats(r, 8));
  if (!rows.IsNull(r, 11)) view.content_sha256 = std::string(rows.Bytes(r, 11));
  view.position = rows.Text(r, 12);
  if (!rows.IsNull(r, 13)) view.global_code = std::string(rows.Bytes(r, 13));
  if (!rows.IsNull(r, 14)) view.global_sample = std::string(rows.Bytes(r, 14));
  view.heading_known = rows.Int32(r, 15) != 0;
  return view;
}

DatabaseRecord ReadDatabaseRow(const Result& rows, int r) {
  DatabaseRecord record;
  record.id = rows.Int64(r, 0);
  record.name = rows.Text(r, 1);
  record.params = rows.Text(r, 2);
  record.created_at = rows.Double(r, 3);
  record.revision = rows.Int64(r, 4);
  record.reload_revision = rows.Int64(r, 5);
  return record;
}

// A bigint[] parameter, as PostgreSQL's text form of an array ("{1,2,3}"), cast in the SQL
// ($n::text::bigint[]): simpler than the binary array format and unambiguous for integers.
std::string BigintArray(const std::vector<int64_t>& ids) {
  return absl::StrCat("{", absl::StrJoin(ids, ","), "}");
}

class PostgresCrossingStore final : public CrossingStore {
 public:
  explicit PostgresCrossingStore(std::shared_ptr<pg::Pool> pool) : pool_(std::move(pool)) {}

  bool shared() const override { return true; }

  absl::StatusOr<std::unique_ptr<DatabaseWriteLock>> LockForWriting(int64_t database_id) override {
    return pg::HoldAdvisoryLock(*pool_, pg::kCrossingWriterLockBase + database_id,
                                absl::StrCat("crossing database ", database_id));
  }

  absl::StatusOr<std::unique_ptr<ChangeFeed>> WatchChanges() override {
    return pg::Listen(pool_->uri(), pg::kCrossingChannel);
  }

  absl::StatusOr<DatabaseRecord> CreateDatabase(const std::string& name,
                                                const std::string& params) override {
    if (name.empty()) return absl::InvalidArgumentError("database name is empty");
    DatabaseRecord record;
    record.name = name;
    record.params = params;
    record.created_at = NowSeconds();
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      absl::StatusOr<Result> inserted = connection.Execute(
          "INSERT INTO crossing_db (name, params, created_at) VALUES ($1, $2, $3) RETURNING id",
          Params().Text(name).Text(params).Double(record.created_at),
          UniqueViolation::kAlreadyExists);
      RETURN_IF_ERROR(NameTaken(inserted.status(), absl::StrCat("database ", Quoted(name))));
      record.id = inserted->Int64(0, 0);
      return Notify(connection, record.id);
    }));
    return record;
  }

  absl::StatusOr<std::vector<DatabaseRecord>> ListDatabases() override {
    std::vector<DatabaseRecord> records;
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(
          Result rows,
          connection.Execute("SELECT id, name, params, created_at, revision, reload_revision "
                             "FROM crossing_db ORDER BY name"));
      for (int r = 0; r < rows.rows(); ++r) records.push_back(ReadDatabaseRow(rows, r));
      return absl::OkStatus();
    }));
    return records;
  }

  absl::StatusOr<DatabaseRecord> GetDatabase(const std::string& name) override {
    DatabaseRecord record;
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(
          Result rows,
          connection.Execute("SELECT id, name, params, created_at, revision, reload_revision "
                             "FROM crossing_db WHERE name = $1",
                             Params().Text(name)));
      if (rows.rows() == 0) {
        return absl::NotFoundError(absl::StrCat("database ", Quoted(name), " not found"));
      }
      record = ReadDatabaseRow(rows, 0);
      return absl::OkStatus();
    }));
    return record;
  }

  absl::Status UpdateDatabaseParams(int64_t database_id, const std::string& params) override {
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(Result updated,
                       connection.Execute("UPDATE crossing_db SET params = $1 WHERE id = $2",
                                          Params().Text(params).Int64(database_id)));
      if (updated.affected() == 0) return DatabaseNotFound(database_id);
      return BumpRevision(connection, database_id, /*reload=*/true);
    });
  }

  absl::Status DeleteDatabase(const std::string& name) override {
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(
          Result found,
          connection.Execute("SELECT id FROM crossing_db WHERE name = $1", Params().Text(name)));
      if (found.rows() == 0) {
        return absl::NotFoundError(absl::StrCat("database ", Quoted(name), " not found"));
      }
      // Waits for an enrollment into it to finish; ON DELETE CASCADE removes the rest.
      RETURN_IF_ERROR(LockDatabase(connection, found.Int64(0, 0)).status());
      RETURN_IF_ERROR(
          connection
              .Execute("DELETE FROM crossing_db WHERE id = $1", Params().Int64(found.Int64(0, 0)))
              .status());
      return Notify(connection, found.Int64(0, 0));
    });
  }

  absl::StatusOr<CrossingRecord> AddCrossing(int64_t database_id, const std::string& name,
                                             const std::string& label) override {
    CrossingRecord record;
    RETURN_IF_ERROR(pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(std::string db_name, LockDatabase(connection, database_id));
      ASSIGN_OR_RETURN(record, InsertCrossing(connection, db_name, {database_id, name, label}));
      return BumpRevision(connection, database_id, /*reload=*/false);
    }));
    return record;
  }

  absl::StatusOr<std::vector<CrossingRecord>> ListCrossings(int64_t database_id) override {
    std::vector<CrossingRecord> records;
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(DatabaseName(connection, database_id).status());
      ASSIGN_OR_RETURN(Result rows,
                       connection.Execute("SELECT id, db_id, name, label FROM crossing "
                                          "WHERE db_id = $1 ORDER BY id",
                                          Params().Int64(database_id)));
      for (int r = 0; r < rows.rows(); ++r) {
        records.push_back({rows.Int64(r, 0), rows.Int64(r, 1), rows.Text(r, 2), rows.Text(r, 3)});
      }
      return absl::OkStatus();
    }));
    return records;
  }

  absl::StatusOr<int> DeleteCrossing(int64_t database_id, int64_t crossing_id,
                                     const std::vector<ClusterRecord>& clusters) override {
    int deleted_views = 0;
    RETURN_IF_ERROR(pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(std::string db_name, LockDatabase(connection, database_id));
      RETURN_IF_ERROR(CheckCrossingOf(connection, database_id, db_name, crossing_id));
      ASSIGN_OR_RETURN(Result count,
                       connection.Execute("SELECT COUNT(*) FROM view WHERE crossing_id = $1",
                                          Params().Int64(crossing_id)));
      deleted_views = static_cast<int>(count.Int64(0, 0));
      // Clusters first: the new ones are validated against the views that remain.
      RETURN_IF_ERROR(DeleteClusters(connection, database_id));
      RETURN_IF_ERROR(
          connection.Execute("DELETE FROM crossing WHERE id = $1",
                             Params().Int64(crossing_id))
              .status());  // cascades to the views and their memberships
      RETURN_IF_ERROR(InsertClusters(connection, database_id, clusters).status());
      return BumpRevision(connection, database_id, /*reload=*/true);
    }));
    return deleted_views;
  }

  absl::StatusOr<AddViewResult> AddView(const ViewRecord& view,
                                        const ClusterAssignment& assignment) override {
    RETURN_IF_ERROR(ValidateView(view));
    AddViewResult result;
    RETURN_IF_ERROR(pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(int64_t database_id, CrossingDatabase(connection, view.crossing_id));
      RETURN_IF_ERROR(LockDatabase(connection, database_id).status());
      ASSIGN_OR_RETURN(result, InsertView(connection, database_id, view, assignment));
      return BumpRevision(connection, database_id, /*reload=*/false);
    }));
    return result;
  }

  absl::StatusOr<AddViewResult> AddViewWithNewCrossing(
      const NewCrossing& crossing, const ViewRecord& view,
      const ClusterAssignment& assignment) override {
    RETURN_IF_ERROR(ValidateView(view));
    AddViewResult result;
    RETURN_IF_ERROR(pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(std::string db_name, LockDatabase(connection, crossing.database_id));
      ASSIGN_OR_RETURN(CrossingRecord created, InsertCrossing(connection, db_name, crossing));
      ViewRecord with_crossing = view;
      with_crossing.crossing_id = created.id;
      ASSIGN_OR_RETURN(result,
                       InsertView(connection, crossing.database_id, with_crossing, assignment));
      return BumpRevision(connection, crossing.database_id, /*reload=*/false);
    }));
    return result;
  }

  absl::StatusOr<ViewReplacementResult> ReplaceViews(const ViewReplacement& replacement) override {
    RETURN_IF_ERROR(ValidateReplacement(replacement));
    const int64_t database_id = replacement.database_id;
    ViewReplacementResult result;
    RETURN_IF_ERROR(pool_->Transaction([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(std::string db_name, LockDatabase(connection, database_id));
      // Clusters first (a deleted centre would take its cluster row along by cascade anyway).
      RETURN_IF_ERROR(DeleteClusters(connection, database_id));
      for (int64_t view_id : replacement.replaced_view_ids) {
        ASSIGN_OR_RETURN(Result removed,
                         connection.Execute("DELETE FROM view WHERE id = $1 AND crossing_id IN "
                                            "(SELECT id FROM crossing WHERE db_id = $2)",
                                            Params().Int64(view_id).Int64(database_id)));
        if (removed.affected() == 0) {
          return absl::NotFoundError(
              absl::StrCat("view ", view_id, " not found in database ", Quoted(db_name)));
        }
      }
      ASSIGN_OR_RETURN(result.clusters,
                       InsertClusters(connection, database_id, replacement.clusters));
      ViewRecord view = replacement.view;
      if (replacement.create_crossing) {
        ASSIGN_OR_RETURN(
            CrossingRecord created,
            InsertCrossing(connection, db_name, {database_id, replacement.crossing_name, ""}));
        view.crossing_id = created.id;
      } else {
        RETURN_IF_ERROR(CheckCrossingOf(connection, database_id, db_name, view.crossing_id));
      }
      ClusterAssignment assignment;
      if (replacement.join_cluster >= 0) {
        assignment.new_cluster = false;
        assignment.cluster_id = result.clusters[replacement.join_cluster].id;
      }
      ASSIGN_OR_RETURN(result.added, InsertView(connection, database_id, view, assignment));
      return BumpRevision(connection, database_id, /*reload=*/true);
    }));
    return result;
  }

  absl::Status ForEachViewAfter(int64_t database_id, int64_t after_view_id,
                                const std::function<absl::Status(ViewRecord&&)>& visit) override {
    RETURN_IF_ERROR(pool_->Run(
        [&](Connection& connection) { return DatabaseName(connection, database_id).status(); }));
    // Pages by id, each its own query: no transaction or connection is held while `visit` runs.
    int64_t after = after_view_id;
    while (true) {
      std::vector<ViewRecord> page;
      RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
        ASSIGN_OR_RETURN(
            Result rows,
            connection.Execute(kSelectViewPage,
                               Params().Int64(database_id).Int64(after).Int64(kViewPage)));
        for (int r = 0; r < rows.rows(); ++r) {
          ASSIGN_OR_RETURN(ViewRecord view, ReadViewRow(rows, r));
          page.push_back(std::move(view));
        }
        return absl::OkStatus();
      }));
      for (ViewRecord& view : page) {
        after = view.id;
        RETURN_IF_ERROR(visit(std::move(view)));
      }
      if (static_cast<int>(page.size()) < kViewPage) return absl::OkStatus();
    }
  }

  absl::StatusOr<std::string> LoadViewImage(int64_t view_id) override {
    return LoadViewBlob(view_id, "image", "stored image");
  }

  absl::StatusOr<std::vector<ClusterRecord>> LoadClusters(int64_t database_id) override {
    std::vector<ClusterRecord> clusters;
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(DatabaseName(connection, database_id).status());
      // LEFT JOIN so that a cluster without members (never written by this code) still shows up.
      ASSIGN_OR_RETURN(Result rows,
                       connection.Execute("SELECT c.id, c.center_view_id, m.view_id FROM cluster c "
                                          "LEFT JOIN cluster_member m ON m.cluster_id = c.id "
                                          "WHERE c.db_id = $1 ORDER BY c.id, m.view_id",
                                          Params().Int64(database_id)));
      for (int r = 0; r < rows.rows(); ++r) {
        const int64_t cluster_id = rows.Int64(r, 0);
        if (clusters.empty() || clusters.back().id != cluster_id) {
          ClusterRecord cluster;
          cluster.id = cluster_id;
          cluster.center_view_id = rows.Int64(r, 1);
          clusters.push_back(std::move(cluster));
        }
        if (!rows.IsNull(r, 2)) clusters.back().member_view_ids.push_back(rows.Int64(r, 2));
      }
      return absl::OkStatus();
    }));
    return clusters;
  }

  absl::Status SaveVocabulary(const VocabularyRecord& vocabulary,
                              const std::vector<ViewCode>& codes) override {
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(LockDatabase(connection, vocabulary.database_id).status());
      RETURN_IF_ERROR(UpdateCodes(connection, vocabulary.database_id, codes));
      RETURN_IF_ERROR(BumpRevision(connection, vocabulary.database_id, /*reload=*/true));
      return connection
          .Execute(
              "INSERT INTO crossing_vocabulary (db_id, trained_views, data, updated_at) "
              "VALUES ($1, $2, $3, $4) ON CONFLICT (db_id) DO UPDATE SET "
              "trained_views = EXCLUDED.trained_views, data = EXCLUDED.data, "
              "updated_at = EXCLUDED.updated_at",
              Params()
                  .Int64(vocabulary.database_id)
                  .Int32(vocabulary.trained_views)
                  .Bytes(vocabulary.data)
                  .Double(NowSeconds()))
          .status();
    });
  }

  absl::Status SaveViewCodes(int64_t database_id, const std::vector<ViewCode>& codes) override {
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(LockDatabase(connection, database_id).status());
      RETURN_IF_ERROR(UpdateCodes(connection, database_id, codes));
      return BumpRevision(connection, database_id, /*reload=*/true);
    });
  }

  absl::StatusOr<std::string> LoadWorkImage(int64_t view_id) override {
    return LoadViewBlob(view_id, "work_image", "working image");
  }

  absl::StatusOr<std::optional<VocabularyRecord>> LoadVocabulary(int64_t database_id) override {
    std::optional<VocabularyRecord> record;
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(Result rows, connection.Execute("SELECT trained_views, data FROM "
                                                       "crossing_vocabulary WHERE db_id = $1",
                                                       Params().Int64(database_id)));
      if (rows.rows() == 0) return absl::OkStatus();
      record.emplace();
      record->database_id = database_id;
      record->trained_views = rows.Int32(0, 0);
      record->data = std::string(rows.Bytes(0, 1));
      return absl::OkStatus();
    }));
    return record;
  }

  absl::StatusOr<std::vector<ClusterRecord>> ReplaceClusters(
      int64_t database_id, const std::vector<ClusterRecord>& clusters) override {
    std::vector<ClusterRecord> inserted;
    RETURN_IF_ERROR(pool_->Transaction([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(LockDatabase(connection, database_id).status());
      RETURN_IF_ERROR(DeleteClusters(connection, database_id));
      ASSIGN_OR_RETURN(inserted, InsertClusters(connection, database_id, clusters));
      return BumpRevision(connection, database_id, /*reload=*/true);
    }));
    return inserted;
  }

 private:
  // The helpers below run on the caller's connection, inside its transaction if it has one.

  // Tells the other servers, when the transaction commits, that the database changed.
  static absl::Status Notify(Connection& connection, int64_t database_id) {
    return connection
        .Execute("SELECT pg_notify($1, $2)",
                 Params().Text(pg::kCrossingChannel).Text(absl::StrCat(database_id)))
        .status();
  }

  // Adds a write to the database's revisions (DatabaseRecord) and notifies.
  static absl::Status BumpRevision(Connection& connection, int64_t database_id, bool reload) {
    RETURN_IF_ERROR(connection
                        .Execute("UPDATE crossing_db SET revision = revision + 1, "
                                 "reload_revision = reload_revision + $2 WHERE id = $1",
                                 Params().Int64(database_id).Int64(reload ? 1 : 0))
                        .status());
    return Notify(connection, database_id);
  }

  // The database's name (for messages), NOT_FOUND when the id is unknown.
  static absl::StatusOr<std::string> DatabaseName(Connection& connection, int64_t database_id) {
    ASSIGN_OR_RETURN(Result rows, connection.Execute("SELECT name FROM crossing_db WHERE id = $1",
                                                     Params().Int64(database_id)));
    if (rows.rows() == 0) return DatabaseNotFound(database_id);
    return rows.Text(0, 0);
  }

  // Takes the database's write lock until the transaction ends, then reads its name (NOT_FOUND
  // when it is unknown or was deleted while we waited).
  static absl::StatusOr<std::string> LockDatabase(Connection& connection, int64_t database_id) {
    RETURN_IF_ERROR(connection
                        .Execute("SELECT pg_advisory_xact_lock($1)",
                                 Params().Int64(pg::kCrossingDatabaseLockBase + database_id))
                        .status());
    return DatabaseName(connection, database_id);
  }

  // The database a crossing belongs to, NOT_FOUND when the crossing is unknown.
  static absl::StatusOr<int64_t> CrossingDatabase(Connection& connection, int64_t crossing_id) {
    ASSIGN_OR_RETURN(Result rows, connection.Execute("SELECT db_id FROM crossing WHERE id = $1",
                                                     Params().Int64(crossing_id)));
    if (rows.rows() == 0) {
      return absl::NotFoundError(absl::StrCat("crossing ", crossing_id, " not found"));
    }
    return rows.Int64(0, 0);
  }

  // NOT_FOUND unless the crossing exists and belongs to the database.
  static absl::Status CheckCrossingOf(Connection& connection, int64_t database_id,
                                      const std::string& db_name, int64_t crossing_id) {
    ASSIGN_OR_RETURN(int64_t crossing_db, CrossingDatabase(connection, crossing_id));
    if (crossing_db != database_id) {
      return absl::NotFoundError(
          absl::StrCat("crossing ", crossing_id, " not found in database ", Quoted(db_name)));
    }
    return absl::OkStatus();
  }

  static absl::StatusOr<CrossingRecord> InsertCrossing(Connection& connection,
                                                       const std::string& db_name,
                                                       const NewCrossing& crossing) {
    if (crossing.name.empty()) return absl::InvalidArgumentError("crossing name is empty");
    absl::StatusOr<Result> inserted = connection.Execute(
        "INSERT INTO crossing (db_id, name, label) VALUES ($1, $2, $3) RETURNING id",
        Params().Int64(crossing.database_id).Text(crossing.name).Text(crossing.label),
        UniqueViolation::kAlreadyExists);
    RETURN_IF_ERROR(NameTaken(inserted.status(), absl::StrCat("crossing ", Quoted(crossing.name),
                                                              " in database ", Quoted(db_name))));
    return CrossingRecord{inserted->Int64(0, 0), crossing.database_id, crossing.name,
                          crossing.label};
  }

  // Inserts a validated view of `database_id` and its cluster membership, unless another view of
  // the database holds the same image (ALREADY_EXISTS). The caller holds the database's lock.
  static absl::StatusOr<AddViewResult> InsertView(Connection& connection, int64_t database_id,
                                                  const ViewRecord& view,
                                                  const ClusterAssignment& assignment) {
    if (!view.content_sha256.empty()) {
      ASSIGN_OR_RETURN(Result same,
                       connection.Execute("SELECT v.id FROM view v JOIN crossing c ON c.id = "
                                          "v.crossing_id WHERE c.db_id = $1 AND "
                                          "v.content_sha256 = $2 LIMIT 1",
                                          Params().Int64(database_id).Bytes(view.content_sha256)));
      if (same.rows() > 0) return DuplicateImage(same.Int64(0, 0), view.content_sha256);
    }
    ASSIGN_OR_RETURN(
        Result inserted,
        connection.Execute(
            "INSERT INTO view (crossing_id, heading_deg, width, height, keypoint_count, "
            "keypoints, descriptors, hue_hist, hue_bins, format_version, image, created_at, "
            "content_sha256, position, work_image, global_code, global_sample, heading_known) "
            "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, "
            "$18) RETURNING id",
            Params()
                .Int64(view.crossing_id)
                .Double(view.heading_deg)
                .Int32(view.width)
                .Int32(view.height)
                .Int32(view.keypoint_count)
                .Floats(view.keypoints)
                .Bytes(view.descriptors)
                .Floats(view.hue_hist)
                .Int32(static_cast<int32_t>(view.hue_hist.size()))
                .Int32(view.format_version)
                // NULL, not an empty blob, marks "image not stored" (LoadViewImage: NOT_FOUND).
                .OptionalBytes(view.image)
                .Double(NowSeconds())
                .OptionalBytes(view.content_sha256)
                .Text(view.position)
                .OptionalBytes(view.work_image)
                .OptionalBytes(view.global_code)
                .OptionalBytes(view.global_sample)
                .Int32(view.heading_known ? 1 : 0)));
    AddViewResult result;
    result.view_id = inserted.Int64(0, 0);
    result.crossing_id = view.crossing_id;
    if (assignment.new_cluster) {
      ASSIGN_OR_RETURN(result.cluster_id,
                       InsertClusterRow(connection, database_id, result.view_id));
    } else {
      ASSIGN_OR_RETURN(Result cluster, connection.Execute("SELECT db_id FROM cluster WHERE id = $1",
                                                          Params().Int64(assignment.cluster_id)));
      if (cluster.rows() == 0) {
        return absl::NotFoundError(absl::StrCat("cluster ", assignment.cluster_id, " not found"));
      }
      if (cluster.Int64(0, 0) != database_id) {
        return absl::InvalidArgumentError(absl::StrCat(
            "cluster ", assignment.cluster_id, " belongs to database ", cluster.Int64(0, 0),
            ", but crossing ", view.crossing_id, " to database ", database_id));
      }
      result.cluster_id = assignment.cluster_id;
    }
    RETURN_IF_ERROR(connection
                        .Execute("INSERT INTO cluster_member (cluster_id, view_id) VALUES ($1, $2)",
                                 Params().Int64(result.cluster_id).Int64(result.view_id))
                        .status());
    return result;
  }

  static absl::Status DeleteClusters(Connection& connection, int64_t database_id) {
    // Memberships go by cascade.
    return connection.Execute("DELETE FROM cluster WHERE db_id = $1", Params().Int64(database_id))
        .status();
  }

  static absl::StatusOr<int64_t> InsertClusterRow(Connection& connection, int64_t database_id,
                                                  int64_t center_view_id) {
    ASSIGN_OR_RETURN(Result inserted,
                     connection.Execute("INSERT INTO cluster (db_id, center_view_id) VALUES "
                                        "($1, $2) RETURNING id",
                                        Params().Int64(database_id).Int64(center_view_id)));
    return inserted.Int64(0, 0);
  }

  // Inserts `clusters` for the database after checking that each one is well formed and that
  // every view exists and belongs to the database (one query for all of them). Returns them in
  // the given order with their new ids.
  static absl::StatusOr<std::vector<ClusterRecord>> InsertClusters(
      Connection& connection, int64_t database_id, const std::vector<ClusterRecord>& clusters) {
    std::vector<int64_t> all_members;
    for (size_t i = 0; i < clusters.size(); ++i) {
      RETURN_IF_ERROR(CheckClusterShape(clusters[i], i));
      all_members.insert(all_members.end(), clusters[i].member_view_ids.begin(),
                         clusters[i].member_view_ids.end());
    }
    ASSIGN_OR_RETURN(Result owners,
                     connection.Execute("SELECT v.id, c.db_id FROM view v JOIN crossing c ON "
                                        "c.id = v.crossing_id WHERE v.id = ANY($1::text::bigint[])",
                                        Params().Text(BigintArray(all_members))));
    std::unordered_map<int64_t, int64_t> database_of;
    for (int r = 0; r < owners.rows(); ++r) database_of[owners.Int64(r, 0)] = owners.Int64(r, 1);
    std::vector<ClusterRecord> inserted;
    inserted.reserve(clusters.size());
    for (size_t i = 0; i < clusters.size(); ++i) {
      const ClusterRecord& cluster = clusters[i];
      for (int64_t view_id : cluster.member_view_ids) {
        const auto owner = database_of.find(view_id);
        if (owner == database_of.end()) {
          return absl::NotFoundError(
              absl::StrCat(ClusterName(cluster, i), ": view ", view_id, " not found"));
        }
        if (owner->second != database_id) {
          return absl::InvalidArgumentError(
              absl::StrCat(ClusterName(cluster, i), ": view ", view_id,
                           " belongs to another database than ", database_id));
        }
      }
      ClusterRecord record = cluster;
      ASSIGN_OR_RETURN(record.id,
                       InsertClusterRow(connection, database_id, cluster.center_view_id));
      RETURN_IF_ERROR(
          connection
              .Execute("INSERT INTO cluster_member (cluster_id, view_id) "
                       "SELECT $1, unnest($2::text::bigint[])",
                       Params().Int64(record.id).Text(BigintArray(cluster.member_view_ids)))
              .status());
      inserted.push_back(std::move(record));
    }
    return inserted;
  }

  // Sets the codes of those views that still belong to `database_id`.
  static absl::Status UpdateCodes(Connection& connection, int64_t database_id,
                                  const std::vector<ViewCode>& codes) {
    for (const ViewCode& c : codes) {
      RETURN_IF_ERROR(
          connection
              .Execute("UPDATE view SET global_code = $1 WHERE id = $2 AND crossing_id "
                       "IN (SELECT id FROM crossing WHERE db_id = $3)",
                       Params().OptionalBytes(c.code).Int64(c.view_id).Int64(database_id))
              .status());
    }
    return absl::OkStatus();
  }

  // One blob column of a view (`column` is ours, never a client's); NOT_FOUND for an unknown view
  // or a NULL blob (`what` names it in the message).
  absl::StatusOr<std::string> LoadViewBlob(int64_t view_id, const char* column, const char* what) {
    std::string blob;
    RETURN_IF_ERROR(pool_->Run([&](Connection& connection) -> absl::Status {
      ASSIGN_OR_RETURN(Result rows, connection.Execute(
                                        absl::StrCat("SELECT ", column, " FROM view WHERE id = $1"),
                                        Params().Int64(view_id)));
      if (rows.rows() == 0) return ViewNotFound(view_id);
      if (rows.IsNull(0, 0)) {
        return absl::NotFoundError(absl::StrCat("view ", view_id, " has no ", what));
      }
      blob = std::string(rows.Bytes(0, 0));
      return absl::OkStatus();
    }));
    return blob;
  }

  std::shared_ptr<pg::Pool> pool_;
};

}  // namespace

std::unique_ptr<CrossingStore> NewPostgresCrossingStore(std::shared_ptr<pg::Pool> pool) {
  return std::make_unique<PostgresCrossingStore>(std::move(pool));
}

}  // namespace waymark::storage
