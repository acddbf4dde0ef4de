#ifndef WAYMARK_STORAGE_CROSSING_STORE_H_
#define WAYMARK_STORAGE_CROSSING_STORE_H_

// What the crossing service persists: databases, crossings, views with their features, clusters.
// Rows and blobs only: no OpenCV, no gRPC. The interface is small so that a PostgreSQL
// implementation can stand beside the SQLite one when a fleet outgrows one server (DESIGN.md).

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::storage {

// Floats stored per keypoint: x, y, size, angle, response, octave.
inline constexpr int kKeypointFloats = 6;
// Bytes per descriptor (SIFT, uint8-valued; lossless for OpenCV's SIFT).
inline constexpr int kDescriptorBytes = 128;
// Version of the feature blobs' layout; bumped when extraction changes incompatibly.
inline constexpr int kFeatureFormatVersion = 1;

struct DatabaseRecord {
  int64_t id = 0;
  std::string name;
  std::string params;  // opaque to storage (the service stores the proto's JSON)
  double created_at = 0;  // unix seconds
  // How servers sharing the database tell that another one changed it (docs/scale-out.md): every
  // write to the database adds 1 to `revision`; the writes that are not appends of crossings and
  // views (deletions, replacements, re-clustering, a vocabulary or codes, new params) also add 1
  // to `reload_revision`, telling a server that it must load the database again rather than read
  // the views after its newest one.
  int64_t revision = 0;
  int64_t reload_revision = 0;
};

struct CrossingRecord {
  int64_t id = 0;
  int64_t database_id = 0;
  std::string name;
  std::string label;
};

struct ViewRecord {
  int64_t id = 0;  // assigned on insert; increasing ids are the enrollment order
  int64_t crossing_id = 0;
  double heading_deg = 0;
  // False for a view taken facing an unknown way (schema v13, issue 34): heading_deg is then 0 and
  // means nothing. Every view before v13 had a heading.
  bool heading_known = true;
  // Where in the crossing the view was taken ("north-kerb", "p2", "t=12.5s"): free text that only
  // tells the views of one heading apart; empty = not tagged (and every view before schema v6).
  std::string position;
  int32_t width = 0;   // working resolution the features were extracted at
  int32_t height = 0;
  int32_t keypoint_count = 0;
  std::vector<float> keypoints;      // keypoint_count * kKeypointFloats
  std::vector<uint8_t> descriptors;  // keypoint_count * kDescriptorBytes
  std::vector<float> hue_hist;       // normalised, any bin count
  int32_t format_version = kFeatureFormatVersion;
  std::string image;  // encoded image bytes; empty when not stored (LoadViews never fills it)
  // SHA-256 (32 bytes, sha256.h) of the encoded image the features came from, whether or not the
  // image is stored: no two views of a database hold the same one. Empty = unknown (views enrolled
  // before schema version 5), which never counts as a duplicate.
  std::string content_sha256;
  // The grey image at working resolution, PNG (schema v7): what the retrieval mode's global
  // descriptor is computed from again when the database's vocabulary is retrained. Empty = not
  // kept (views enrolled before v7). Written by AddView; LoadViews and ForEachView leave it empty
  // (it is read back only for retraining, with LoadWorkImage).
  std::string work_image;
  // The retrieval mode's global stage (schema v8), opaque bytes of the service: the view's code
  // under the vocabulary it names, and the sample of its dense descriptors a retraining uses.
  // Empty = none.
  std::string global_code;
  std::string global_sample;
};

// A view's global code, written when the vocabulary it belongs to is saved or later.
struct ViewCode {
  int64_t view_id = 0;
  std::string code;
};

// A database's global-descriptor vocabulary (the engine's bytes, opaque here).
struct VocabularyRecord {
  int64_t database_id = 0;
  int32_t trained_views = 0;  // how many views it was trained on (the retraining schedule's)
  std::string data;
};

// A cluster as the clustering produced it: centre first, then the other members.
struct ClusterRecord {
  int64_t id = 0;  // assigned on insert
  int64_t center_view_id = 0;
  std::vector<int64_t> member_view_ids;  // includes the centre
};

// Where a newly enrolled view goes: a new cluster with itself as centre, or an existing cluster.
struct ClusterAssignment {
  bool new_cluster = true;
  int64_t cluster_id = 0;  // when !new_cluster
};

struct AddViewResult {
  int64_t view_id = 0;
  int64_t cluster_id = 0;
  int64_t crossing_id = 0;  // the view's crossing (the new one for AddViewWithNewCrossing)
};

// A crossing created together with its first view.
struct NewCrossing {
  int64_t database_id = 0;
  std::string name;
  std::string label;
};

// A view that takes the place of others (an enrollment with `replace`), all in one transaction.
struct ViewReplacement {
  int64_t database_id = 0;
  std::vector<int64_t> replaced_view_ids;  // deleted; each must belong to the database
  // The database's clusters after the deletion, computed by the caller over the remaining views
  // (without the new one); they replace all of its clusters, as in DeleteCrossing.
  std::vector<ClusterRecord> clusters;
  ViewRecord view;                     // the new view
  int join_cluster = -1;               // index into `clusters` the view joins; -1 = a new cluster
  bool create_crossing = false;        // create view's crossing (then view.crossing_id is ignored)
  std::string crossing_name;           // when create_crossing
};

struct ViewReplacementResult {
  AddViewResult added;
  std::vector<ClusterRecord> clusters;  // `clusters` as stored (new ids), in the given order
};

// Held while a server writes to one crossing database (LockForWriting).
class DatabaseWriteLock {
 public:
  virtual ~DatabaseWriteLock() = default;
};

// Tells a server that another one changed some crossing database (WatchChanges).
class ChangeFeed {
 public:
  virtual ~ChangeFeed() = default;
  // Waits up to `timeout_ms` for changes; true when any arrived since the last call (all of them
  // are consumed). UNAVAILABLE when the connection is lost: changes may have been missed, so the
  // caller looks at every database again and opens a new feed.
  virtual absl::StatusOr<bool> Wait(int timeout_ms) = 0;
};

// Every mutating call is one transaction: it happens entirely or not at all, and adds to the
// database's revisions as DatabaseRecord says (each call exactly 1 to `revision`; the calls marked
// "reload" below also 1 to `reload_revision`).
// Errors: NOT_FOUND (unknown id/name), ALREADY_EXISTS (duplicate name), INVALID_ARGUMENT (blob sizes
// inconsistent with counts), UNAVAILABLE (the database cannot be reached, or stayed locked by
// another writer), INTERNAL (a database failure, the message carries the database's text).
class CrossingStore {
 public:
  virtual ~CrossingStore() = default;

  // True when other servers may write to the same database (PostgreSQL): a server then takes
  // LockForWriting around its writes and follows WatchChanges. A SQLite file has one server
  // (storage/database_lock.h).
  virtual bool shared() const = 0;
  // Excludes every other holder, in this process or another, from writing to the database until
  // the lock is destroyed: what keeps the clustering of one database consistent when servers
  // enroll into it at once. Waits up to 30 s, then UNAVAILABLE. Where the store is not shared it
  // excludes nothing (the caller's own locks do).
  virtual absl::StatusOr<std::unique_ptr<DatabaseWriteLock>> LockForWriting(
      int64_t database_id) = 0;
  // A feed of other servers' changes; nullptr where the store is not shared.
  virtual absl::StatusOr<std::unique_ptr<ChangeFeed>> WatchChanges() = 0;

  virtual absl::StatusOr<DatabaseRecord> CreateDatabase(const std::string& name,
                                                        const std::string& params) = 0;
  virtual absl::StatusOr<std::vector<DatabaseRecord>> ListDatabases() = 0;
  virtual absl::StatusOr<DatabaseRecord> GetDatabase(const std::string& name) = 0;
  // Reload.
  virtual absl::Status UpdateDatabaseParams(int64_t database_id, const std::string& params) = 0;
  // Deletes the database with its crossings, views and clusters.
  virtual absl::Status DeleteDatabase(const std::string& name) = 0;

  virtual absl::StatusOr<CrossingRecord> AddCrossing(int64_t database_id, const std::string& name,
                                                     const std::string& label) = 0;
  virtual absl::StatusOr<std::vector<CrossingRecord>> ListCrossings(int64_t database_id) = 0;
  // Deletes the crossing and its views, and replaces the database's clusters by `clusters`
  // (computed by the caller over the remaining views), all in one transaction. Reload.
  // Returns the number of views deleted.
  virtual absl::StatusOr<int> DeleteCrossing(int64_t database_id, int64_t crossing_id,
                                             const std::vector<ClusterRecord>& clusters) = 0;

  // Inserts the view and its cluster membership in one transaction. ALREADY_EXISTS, with nothing
  // stored, when another view of the database has the same content_sha256: the check and the
  // insert are one write transaction, so two enrollments of the same image store it once even
  // from two connections.
  virtual absl::StatusOr<AddViewResult> AddView(const ViewRecord& view,
                                                const ClusterAssignment& assignment) = 0;
  // The same for a view of a crossing that does not exist yet: creates the crossing, the view and
  // its membership in one transaction (view.crossing_id is ignored), so a crash or a failed insert
  // never leaves a crossing behind that its enrollment did not complete. ALREADY_EXISTS when the
  // name is taken.
  virtual absl::StatusOr<AddViewResult> AddViewWithNewCrossing(
      const NewCrossing& crossing, const ViewRecord& view, const ClusterAssignment& assignment) = 0;
  // Deletes views and adds the one that replaces them (ViewReplacement), with the new clusters.
  // Reload.
  // NOT_FOUND when a replaced view is not in the database; ALREADY_EXISTS as AddView.
  virtual absl::StatusOr<ViewReplacementResult> ReplaceViews(const ViewReplacement& replacement) = 0;
  // All views of a database in enrollment (id) order, without image bytes: ForEachView, collected.
  absl::StatusOr<std::vector<ViewRecord>> LoadViews(int64_t database_id);
  // The same, one view at a time, so a server loading thousands of views never holds all the
  // rows at once. Stops at the first error `visit` returns and returns it.
  absl::Status ForEachView(int64_t database_id,
                           const std::function<absl::Status(ViewRecord&&)>& visit) {
    return ForEachViewAfter(database_id, 0, visit);
  }
  // The views whose id is above `after_view_id`: what another server enrolled since this one's
  // newest view.
  virtual absl::Status ForEachViewAfter(
      int64_t database_id, int64_t after_view_id,
      const std::function<absl::Status(ViewRecord&&)>& visit) = 0;
  // Encoded image of a view, NOT_FOUND when it was not stored.
  virtual absl::StatusOr<std::string> LoadViewImage(int64_t view_id) = 0;
  // Clusters in id order, members in view id order (centre included).
  virtual absl::StatusOr<std::vector<ClusterRecord>> LoadClusters(int64_t database_id) = 0;
  // Stores (replacing) the database's vocabulary and, in the same transaction, the views' codes
  // under it. Codes of views that are no longer in the database (deleted while the vocabulary was
  // being trained) are skipped. NOT_FOUND for an unknown database. Reload.
  virtual absl::Status SaveVocabulary(const VocabularyRecord& vocabulary,
                                      const std::vector<ViewCode>& codes) = 0;
  // Replaces the codes of views of the database (skipping views it no longer holds). Reload.
  virtual absl::Status SaveViewCodes(int64_t database_id, const std::vector<ViewCode>& codes) = 0;
  // The grey working image of a view (ViewRecord::work_image); NOT_FOUND when none was kept.
  virtual absl::StatusOr<std::string> LoadWorkImage(int64_t view_id) = 0;
  // The database's vocabulary; nullopt when none was saved.
  virtual absl::StatusOr<std::optional<VocabularyRecord>> LoadVocabulary(int64_t database_id) = 0;
  // Replaces all clusters of the database (ids are reassigned; returned in the given order).
  // Reload.
  virtual absl::StatusOr<std::vector<ClusterRecord>> ReplaceClusters(
      int64_t database_id, const std::vector<ClusterRecord>& clusters) = 0;
};

// Opens (creating if needed) a SQLite file and migrates it to the current schema. The parent
// directory is created. ":memory:" gives a private in-memory database (tests).
absl::StatusOr<std::unique_ptr<CrossingStore>> OpenSqliteCrossingStore(const std::string& path);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_CROSSING_STORE_H_
