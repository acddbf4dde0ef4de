#ifndef WAYMARK_STORAGE_POSTGRES_PG_COORDINATION_H_
#define WAYMARK_STORAGE_POSTGRES_PG_COORDINATION_H_

// How servers sharing one PostgreSQL database coordinate (issue 19, docs/scale-out.md): a
// session-level advisory lock held across a server's write to one crossing database, and
// LISTEN/NOTIFY to hear about the others' writes.

#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "storage/crossing_store.h"
#include "storage/postgres/pg.h"

namespace waymark::storage::pg {

// The NOTIFY channel of crossing-database changes; the payload is the database's id.
inline constexpr char kCrossingChannel[] = "waymark_crossing";
// Advisory-lock keys of the write locks (pg_schema.h holds the transaction-scoped ones).
inline constexpr int64_t kCrossingWriterLockBase = 0x574d570000000000;  // "WMW" + db id

// Holds advisory lock `key` on a connection of `pool` until destroyed. Waits up to 30 s for
// another holder (in any process), then UNAVAILABLE. If the connection dies, PostgreSQL drops
// the lock with it, so a crashed server never leaves a database locked.
absl::StatusOr<std::unique_ptr<DatabaseWriteLock>> HoldAdvisoryLock(Pool& pool, int64_t key,
                                                                    const std::string& what);

// A dedicated connection LISTENing on `channel`.
absl::StatusOr<std::unique_ptr<ChangeFeed>> Listen(const std::string& uri,
                                                   const std::string& channel);

}  // namespace waymark::storage::pg

#endif  // WAYMARK_STORAGE_POSTGRES_PG_COORDINATION_H_
