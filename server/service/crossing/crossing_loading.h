#ifndef WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_LOADING_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_LOADING_H_

// Bringing a crossing database from the store into memory: whole at start-up, and, when servers
// share the database (PostgreSQL, docs/scale-out.md), what another server changed since this one
// last looked. A write to a shared database runs inside a WriteScope: the database's fleet-wide
// write lock, taken first, and the database caught up under it, so that the clustering decision
// that follows sees every view any server has enrolled.

#include <cstdint>
#include <memory>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/crossing/view_database.h"
#include "server/service/crossing/crossing_database.h"
#include "server/service/crossing/folder.h"
#include "storage/crossing_store.h"

namespace waymark::service {

// The database as stored: crossings, views (indexed), clusters, vocabulary and codes.
absl::StatusOr<std::shared_ptr<ResidentDatabase>> LoadResidentDatabase(
    storage::CrossingStore& store, const crossing::IndexOptions& index,
    const storage::DatabaseRecord& record);

// Makes `db` what the store holds, if another server changed it: nothing when the revisions
// agree; the views after its newest one, new crossings and the clusters when only appends
// happened; a full load otherwise (swapped in under the exclusive lock, so requests holding `db`
// keep a valid object). Needs no write lock: a reading that another server's commit overlapped
// (the revision moved meanwhile) is read again, and after a few such readings under the lock, so
// that only one consistent state is ever applied. Takes db.mutex itself, exclusively only to
// apply. NOT_FOUND when the database was deleted (or deleted and created again) in the store.
absl::Status CatchUp(storage::CrossingStore& store, const crossing::IndexOptions& index,
                     ResidentDatabase& db);

// Held around one write to a database (crossing_registry.h: taken before db.mutex).
class WriteScope {
 public:
  // Takes the database's write lock and catches it up when the store is shared; does nothing
  // otherwise (one server per SQLite file).
  static absl::StatusOr<WriteScope> Begin(storage::CrossingStore& store,
                                          const crossing::IndexOptions& index,
                                          ResidentDatabase& db);

 private:
  explicit WriteScope(std::unique_ptr<storage::DatabaseWriteLock> lock) : lock_(std::move(lock)) {}
  std::unique_ptr<storage::DatabaseWriteLock> lock_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_LOADING_H_
