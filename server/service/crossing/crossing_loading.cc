#include "server/service/crossing/crossing_loading.h"

#include <algorithm>
#include <optional>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "server/crossing/features.h"
#include "server/service/crossing/global_stage.h"
#include "server/service/crossing/params.h"

namespace waymark::service {
namespace {

// Adds a stored view to the database in memory (caller holds db.mutex exclusively, or owns a
// database no one else sees yet). With `defer_indexing`, the caller finishes the index once for
// all views (ViewDatabase::FinishLoading).
absl::Status AddStoredView(ResidentDatabase& db, storage::ViewRecord&& v, bool defer_indexing) {
  const crossing::FeatureOptions& f = db.options.features;
  // With keep_aspect a view fills the working size along one side.
  const bool size_fits = f.keep_aspect ? (v.width <= f.work_width && v.height <= f.work_height &&
                                          (v.width == f.work_width || v.height == f.work_height))
                                       : (v.width == f.work_width && v.height == f.work_height);
  if (v.format_version != storage::kFeatureFormatVersion || !size_fits) {
    return absl::FailedPreconditionError(absl::StrCat(
        "view ", v.id, " was extracted with format ", v.format_version, " at ", v.width, "x",
        v.height, ", not what this server uses: re-enroll the database"));
  }
  std::vector<cv::Point2f> points(v.keypoint_count);
  for (int i = 0; i < v.keypoint_count; ++i) {
    points[i] = {v.keypoints[i * storage::kKeypointFloats],
                 v.keypoints[i * storage::kKeypointFloats + 1]};
  }
  const cv::Mat descriptors(v.keypoint_count, crossing::kDescriptorSize, CV_8U,
                            v.descriptors.data());
  // A view stored with no heading (schema v13) holds NaN in memory (crossing_database.h).
  const double heading = v.heading_known ? v.heading_deg : kNoHeading;
  const uint32_t slot = db.views->AddView(v.id, v.crossing_id, heading, descriptors,
                                          std::move(points), std::move(v.hue_hist), defer_indexing);
  db.views->SetPosition(slot, std::move(v.position));
  LoadGlobalView(db, slot, v);
  db.views_per_crossing[v.crossing_id]++;
  db.contents.Add(v.id, v.content_sha256);
  db.keypoints += v.keypoint_count;
  return absl::OkStatus();
}

absl::Status Gone(const std::string& name) {
  return absl::NotFoundError(
      absl::StrCat("database \"", name, "\" was deleted by another server"));
}

}  // namespace

absl::StatusOr<std::shared_ptr<ResidentDatabase>> LoadResidentDatabase(
    storage::CrossingStore& store, const crossing::IndexOptions& index,
    const storage::DatabaseRecord& record) {
  auto db = std::make_shared<ResidentDatabase>();
  db->record = record;
  absl::StatusOr<v1::DatabaseParams> params = ParamsFromJson(record.params);
  if (!params.ok()) return params.status();
  db->params = *params;
  db->options = ToDatabaseOptions(db->params);
  db->views = std::make_unique<crossing::ViewDatabase>(index);

  absl::StatusOr<std::vector<storage::CrossingRecord>> crossings = store.ListCrossings(record.id);
  if (!crossings.ok()) return crossings.status();
  for (const auto& c : *crossings) db->AddCrossingRecord(c);
  absl::StatusOr<std::optional<storage::VocabularyRecord>> vocabulary =
      store.LoadVocabulary(record.id);
  if (!vocabulary.ok()) return vocabulary.status();
  LoadGlobalVocabulary(*db, *vocabulary);

  // One view at a time: a large database never sits in memory twice (rows and index).
  const absl::Status loaded = store.ForEachView(record.id, [&](storage::ViewRecord&& v) {
    return AddStoredView(*db, std::move(v), /*defer_indexing=*/true);
  });
  if (!loaded.ok()) return loaded;
  db->views->FinishLoading();
  absl::StatusOr<std::vector<storage::ClusterRecord>> clusters = store.LoadClusters(record.id);
  if (!clusters.ok()) return clusters.status();
  ResidentDatabase::InstallClusters(*clusters, db->views.get());
  return db;
}

namespace {

// What another server changed, read from the store (nothing is applied yet).
struct StoredChanges {
  storage::DatabaseRecord record;  // as stored when the reading began
  bool none = false;               // the revisions agree: nothing to do
  std::shared_ptr<ResidentDatabase> fresh;  // a full load, when a reload is due
  std::vector<storage::CrossingRecord> crossings;  // otherwise: all crossings,
  std::vector<storage::ViewRecord> views;          // the views after the newest one held,
  std::vector<storage::ClusterRecord> clusters;    // and all clusters
};

absl::StatusOr<StoredChanges> ReadChanges(storage::CrossingStore& store,
                                          const crossing::IndexOptions& index,
                                          const storage::DatabaseRecord& known,
                                          int64_t newest_view, bool reload) {
  StoredChanges changes;
  absl::StatusOr<storage::DatabaseRecord> stored = store.GetDatabase(known.name);
  if (absl::IsNotFound(stored.status())) return Gone(known.name);
  if (!stored.ok()) return stored.status();
  if (stored->id != known.id) return Gone(known.name);
  changes.record = *stored;
  if (stored->revision == known.revision && stored->reload_revision == known.reload_revision) {
    changes.none = true;
    return changes;
  }
  if (reload || stored->reload_revision != known.reload_revision ||
      stored->params != known.params) {
    // Views deleted or replaced, re-clustered, a new vocabulary: load it again.
    absl::StatusOr<std::shared_ptr<ResidentDatabase>> fresh =
        LoadResidentDatabase(store, index, *stored);
    if (!fresh.ok()) return fresh.status();
    changes.fresh = *std::move(fresh);
    return changes;
  }
  // Only appends: the new crossings and views, and the clusters they joined or started.
  absl::StatusOr<std::vector<storage::CrossingRecord>> crossings = store.ListCrossings(known.id);
  if (!crossings.ok()) return crossings.status();
  changes.crossings = *std::move(crossings);
  const absl::Status read =
      store.ForEachViewAfter(known.id, newest_view, [&changes](storage::ViewRecord&& v) {
        changes.views.push_back(std::move(v));
        return absl::OkStatus();
      });
  if (!read.ok()) return read;
  absl::StatusOr<std::vector<storage::ClusterRecord>> clusters = store.LoadClusters(known.id);
  if (!clusters.ok()) return clusters.status();
  changes.clusters = *std::move(clusters);
  return changes;
}

// True when the database is still at the revision the changes were read at: nothing committed
// during the reading, so they are one consistent state.
absl::StatusOr<bool> StillAt(storage::CrossingStore& store, const storage::DatabaseRecord& record) {
  absl::StatusOr<storage::DatabaseRecord> now = store.GetDatabase(record.name);
  if (absl::IsNotFound(now.status())) return Gone(record.name);
  if (!now.ok()) return now.status();
  return now->id == record.id && now->revision == record.revision;
}

// Puts the appended views into their clusters as enrollment does (a new cluster for a view that
// is its centre, else the existing one), in id order: no rebuild of the centre index, which
// InstallClusters would do. False, having changed nothing, when the stored clusters are not
// this database's plus those appends (then the caller installs them whole).
bool JoinClusters(ResidentDatabase& db, const std::vector<int64_t>& added,
                  const std::vector<storage::ClusterRecord>& stored) {
  std::unordered_map<int64_t, const storage::ClusterRecord*> cluster_of;
  for (const storage::ClusterRecord& c : stored) {
    for (int64_t id : c.member_view_ids) cluster_of[id] = &c;
  }
  std::unordered_map<int64_t, int> index_of;  // cluster id -> index in memory
  for (size_t i = 0; i < db.views->clusters().size(); ++i) {
    index_of[db.views->clusters()[i].cluster_id] = static_cast<int>(i);
  }
  // Check first, so that a mismatch changes nothing.
  size_t new_clusters = 0;
  for (int64_t id : added) {
    auto found = cluster_of.find(id);
    if (found == cluster_of.end()) return false;
    if (!index_of.count(found->second->id)) {
      if (found->second->center_view_id != id) return false;
      ++new_clusters;
    }
  }
  if (db.views->clusters().size() + new_clusters != stored.size()) return false;
  for (int64_t id : added) {
    const storage::ClusterRecord& cluster = *cluster_of.at(id);
    const uint32_t slot =
        static_cast<uint32_t>(db.FindView(id) - db.views->views().data());
    auto known = index_of.find(cluster.id);
    if (known != index_of.end()) {
      db.views->AddToCluster(known->second, slot);
    } else {
      index_of[cluster.id] = db.views->NewCluster(cluster.id, slot);
    }
  }
  return true;
}

absl::Status Apply(ResidentDatabase& db, StoredChanges changes, int64_t newest_view) {
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  if (changes.fresh != nullptr) {
    db.TakeContentsOf(std::move(*changes.fresh));
    return absl::OkStatus();
  }
  // Another catch-up may have run since this one looked: then start again from the top.
  const int64_t newest_now = db.views->views().empty() ? 0 : db.views->views().back().view_id;
  if (newest_now != newest_view) return absl::AbortedError("caught up meanwhile");
  for (const auto& c : changes.crossings) {
    if (!db.crossings.count(c.id)) db.AddCrossingRecord(c);
  }
  // Every clustered view must be held once the new ones are in; if not, memory missed views
  // (which the revisions should make impossible) and only a full load can repair it.
  std::set<int64_t> held;
  for (const storage::ViewRecord& v : changes.views) held.insert(v.id);
  for (const storage::ClusterRecord& c : changes.clusters) {
    for (int64_t id : c.member_view_ids) {
      if (!held.count(id) && db.FindView(id) == nullptr) {
        return absl::DataLossError(absl::StrCat("view ", id, " is clustered but not held"));
      }
    }
  }
  std::vector<int64_t> added;
  for (storage::ViewRecord& v : changes.views) {
    added.push_back(v.id);
    if (absl::Status s = AddStoredView(db, std::move(v), /*defer_indexing=*/false); !s.ok()) {
      return s;
    }
  }
  if (!JoinClusters(db, added, changes.clusters)) {
    ResidentDatabase::InstallClusters(changes.clusters, db.views.get());
  }
  db.record = changes.record;
  return absl::OkStatus();
}

// Reads from the store until it reads one consistent state, then applies it. Without the write
// lock (`locked` false) a reading that a commit overlapped is read again, a few times, and then
// under the lock.
absl::Status CatchUpImpl(storage::CrossingStore& store, const crossing::IndexOptions& index,
                         ResidentDatabase& db, bool locked) {
  constexpr int kOptimisticReadings = 3;
  bool reload = false;
  for (int reading = 0;; ++reading) {
    storage::DatabaseRecord known;
    int64_t newest_view = 0;
    {
      absl::ReaderMutexLock lock(&db.mutex);
      if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
      known = db.record;
      if (!db.views->views().empty()) newest_view = db.views->views().back().view_id;
    }
    absl::StatusOr<StoredChanges> changes = ReadChanges(store, index, known, newest_view, reload);
    if (!changes.ok()) return changes.status();
    if (changes->none) return absl::OkStatus();
    if (!locked) {
      absl::StatusOr<bool> consistent = StillAt(store, changes->record);
      if (!consistent.ok()) return consistent.status();
      if (!*consistent) {
        if (reading + 1 < kOptimisticReadings) continue;
        absl::StatusOr<std::unique_ptr<storage::DatabaseWriteLock>> lock =
            store.LockForWriting(known.id);
        if (!lock.ok()) return lock.status();
        return CatchUpImpl(store, index, db, /*locked=*/true);
      }
    }
    const absl::Status applied = Apply(db, *std::move(changes), newest_view);
    if (absl::IsDataLoss(applied) && !reload) {
      spdlog::warn("database \"{}\": {}; loading it again", known.name,
                   std::string(applied.message()));
      reload = true;
      continue;
    }
    if (!absl::IsAborted(applied)) return applied;
  }
}

}  // namespace

absl::Status CatchUp(storage::CrossingStore& store, const crossing::IndexOptions& index,
                     ResidentDatabase& db) {
  return CatchUpImpl(store, index, db, /*locked=*/false);
}

absl::StatusOr<WriteScope> WriteScope::Begin(storage::CrossingStore& store,
                                             const crossing::IndexOptions& index,
                                             ResidentDatabase& db) {
  if (!store.shared()) return WriteScope(nullptr);
  absl::StatusOr<std::unique_ptr<storage::DatabaseWriteLock>> lock =
      store.LockForWriting(db.record.id);
  if (!lock.ok()) return lock.status();
  if (absl::Status s = CatchUpImpl(store, index, db, /*locked=*/true); !s.ok()) return s;
  return WriteScope(*std::move(lock));
}

}  // namespace waymark::service
