#ifndef WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_DATABASE_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_DATABASE_H_

// One crossing database as the registry holds it in memory (crossing_registry.h explains the
// locking), and what the registry's operations on it share: name and heading rules, the index of
// stored images, copying the views without some of them (deleting a crossing, replacing views).

#include <cstdint>
#include <functional>
#include <map>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "server/crossing/features.h"
#include "server/crossing/view_database.h"
#include "server/service/crossing/folder.h"
#include "server/service/crossing/params.h"
#include "storage/crossing_store.h"

namespace waymark::service {

// 1-128 characters, no '/' and no control characters (crossing names are folder names in
// `waymark enroll` layouts and appear in logs).
absl::Status ValidateCrossingName(const std::string& name);
// A compass heading in [0, 360) degrees.
absl::Status ValidateHeading(double heading_deg);
// A view's capture position: empty, or up to 64 characters without control characters.
absl::Status ValidatePosition(const std::string& position);
// Headings that name the same view direction (they come from file names and JSON, so exact
// equality of the decimal values is what "the same" means; the tolerance only absorbs rounding).
// Two NaN headings (views with no heading, kNoHeading) are the same; NaN and a number are not.
bool SameHeading(double a_deg, double b_deg);

// In memory (crossing::ViewEntry::heading_deg) a view enrolled with no heading holds NaN: a
// recognition that picks it answers the crossing and no heading (issue 34).
inline constexpr double kNoHeading = std::numeric_limits<double>::quiet_NaN();
// The heading an enrollment request gives its view: kNoHeading with heading_unknown.
double RequestedHeading(const v1::EnrollViewRequest& request);

// Which stored view holds which image: the SHA-256 of its encoded bytes (storage/sha256.h).
// Views enrolled before hashes were stored are not in it.
class ViewContents {
 public:
  void Add(int64_t view_id, const std::string& sha256);  // an empty (unknown) hash is ignored
  void Remove(int64_t view_id);
  // The view holding the image, if any.
  std::optional<int64_t> Find(const std::string& sha256) const;

 private:
  std::unordered_map<std::string, int64_t> view_by_hash_;
  std::unordered_map<int64_t, std::string> hash_by_view_;
};

// The retrieval mode's global stage of a database in memory (global_stage.h runs it).
struct GlobalStageState {
  uint64_t vocabulary = 0;  // fingerprint of views->vocabulary(); 0 = none yet
  int trained_views = 0;    // views it was learnt from
  // Views that have no code under the current vocabulary but can get one (enrolled while it was
  // being learnt, or loaded with a code of an older vocabulary).
  std::set<int64_t> uncoded;
  bool scheduled = false;  // queued for, or being worked on by, the global stage worker
};

struct ResidentDatabase {
  storage::DatabaseRecord record;
  v1::DatabaseParams params;  // effective values
  DatabaseOptions options;
  std::unique_ptr<crossing::ViewDatabase> views;
  std::map<int64_t, storage::CrossingRecord> crossings;  // by id
  std::map<std::string, int64_t> crossing_ids;           // by name
  std::map<int64_t, int> views_per_crossing;
  ViewContents contents;
  int64_t keypoints = 0;
  GlobalStageState global;
  bool deleted = false;  // requests that still hold a pointer get NOT_FOUND
  mutable absl::Mutex mutex;

  absl::Status CheckAlive() const;
  // After a write of this server to the store (with db.mutex held exclusively): the revisions the
  // store now has (crossing_store.h says which writes are reloads), so that the next write does
  // not take its own changes for another server's.
  void NoteOwnWrite(bool reload) {
    ++record.revision;
    if (reload) ++record.reload_revision;
  }
  // Takes the contents of a freshly loaded copy (db.mutex held exclusively): what a full catch-up
  // does, so that requests holding this object keep a valid one.
  void TakeContentsOf(ResidentDatabase&& fresh);
  void AddCrossingRecord(const storage::CrossingRecord& c);
  // The crossing's name, "" when unknown.
  std::string CrossingName(int64_t crossing_id) const;
  // The view with this storage id, nullptr when there is none (slots are in view id order).
  const crossing::ViewEntry* FindView(int64_t view_id) const;

  // Installs clusters given as storage records (view ids) into `target`.
  static void InstallClusters(const std::vector<storage::ClusterRecord>& records,
                              crossing::ViewDatabase* target);
  // Clusters of `source` (slots) as storage records (view ids).
  static std::vector<storage::ClusterRecord> ToRecords(
      const crossing::ViewDatabase& source, const std::vector<crossing::ClusterEntry>& clusters);
};

// The views of `source` for which `drop` is false, in the same order, indexed and without
// clusters: what stays when a crossing is deleted or views are replaced. The index cannot forget
// a view, so this copies the rest (descriptors included) and rebuilds it.
struct RemainingViews {
  std::unique_ptr<crossing::ViewDatabase> views;
  int64_t keypoints = 0;
  std::vector<int64_t> dropped_view_ids;
  std::map<int64_t, int> dropped_per_crossing;  // crossing id -> views dropped
};
RemainingViews CopyViewsExcept(const crossing::ViewDatabase& source,
                               const std::function<bool(const crossing::ViewEntry&)>& drop,
                               const crossing::IndexOptions& index_options);

// The storage row of a view from its extracted features (no image, no hash).
storage::ViewRecord ToViewRecord(int64_t crossing_id, double heading_deg,
                                 const crossing::ImageFeatures& features);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_DATABASE_H_
