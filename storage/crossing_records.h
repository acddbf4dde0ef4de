#ifndef WAYMARK_STORAGE_CROSSING_RECORDS_H_
#define WAYMARK_STORAGE_CROSSING_RECORDS_H_

// What both crossing stores (SQLite, PostgreSQL) check and say the same way: a view's blobs
// against its counts before it is written and after it is read, a cluster's shape, and the
// messages of the errors their callers show to operators.

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "storage/crossing_store.h"

namespace waymark::storage {

// The blob sizes must agree with the counts, or a later read would misinterpret the arrays; the
// heading must be finite and the content hash a SHA-256 digest or nothing.
absl::Status ValidateView(const ViewRecord& view);

// ValidateView of the new view, and the cluster it joins one of the replacement's clusters.
absl::Status ValidateReplacement(const ViewReplacement& replacement);

// DATA_LOSS unless a stored blob holds exactly `expected` bytes (the file was truncated, edited by
// hand or written by a buggy build).
absl::Status CheckStoredBlobSize(int64_t actual, int64_t expected, int64_t view_id,
                                 const char* what);

// A cluster about to be stored: the centre among its members, no member twice. `index` numbers it
// in the message.
absl::Status CheckClusterShape(const ClusterRecord& cluster, size_t index);
// "cluster #<index> (centre view <id>)", how the messages about a cluster start.
std::string ClusterName(const ClusterRecord& cluster, size_t index);

// Replaces the message of an ALREADY_EXISTS status (a database's "UNIQUE constraint failed: ..."
// means nothing to a robot operator) by "<what> already exists"; other statuses pass through.
absl::Status NameTaken(absl::Status status, const std::string& what);

// ALREADY_EXISTS: view `view_id` of the database already holds the image with this digest.
absl::Status DuplicateImage(int64_t view_id, const std::string& content_sha256);

absl::Status DatabaseNotFound(int64_t database_id);
absl::Status ViewNotFound(int64_t view_id);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_CROSSING_RECORDS_H_
