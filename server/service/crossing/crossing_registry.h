#ifndef WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_REGISTRY_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_REGISTRY_H_

// The crossing databases a server holds: each one in memory (features, index, clusters) and in
// the store, kept consistent. This is the application layer between the gRPC handlers and the
// engine + storage; it speaks the API's messages but no gRPC, so it is tested without a server.
//
// Concurrency (many robots on one database; docs/multi-robot.md):
// - A reader/writer lock per database. Recognitions share it. An enrollment extracts features
//   outside the lock (the slow part), then takes it exclusively only to pick the view's cluster,
//   commit one transaction (view, its features, its cluster membership and, for a first view, its
//   crossing) and update memory. Disk first, then memory, under the same exclusive lock: memory
//   never holds what the disk does not, and a recognition sees a view completely (features, index
//   entry, cluster, crossing name) or not at all.
// - The lock is absl::Mutex, which does not starve writers: with glibc's std::shared_mutex a steady
//   stream of overlapping recognitions could keep an enrollment waiting indefinitely.
// - Feature extraction, the slow and memory-hungry step of both, runs at most
//   ExtractionLimits::max_running at a time; beyond max_waiting more, a request is answered
//   RESOURCE_EXHAUSTED at once (work_gate.h).
// - Enrollments of one database are serialised, so view ids (SQLite AUTOINCREMENT, taken inside
//   the lock) are the order in which views entered memory; the registry-wide lock guards only the
//   name -> database map.
//
// Clustering is incremental and synchronous: each enrolled view is matched against the current
// cluster centres and joins the best one that reaches the threshold, or becomes the centre of a new
// cluster (the paper's sequential clustering), in the enrollment's own transaction. No background job
// clusters and there is no window in which clusters lag behind views. RebuildClusters re-runs the same
// sequential clustering over all views in id order, so after any interleaving of concurrent
// enrollments it reproduces the incremental clusters exactly (the integration test checks this);
// it is needed only after a threshold change, and DeleteCrossing re-clusters the remaining views.
//
// The one background job is the retrieval mode's global stage (global_stage.h): a worker thread
// learns each database's vocabulary and codes its views outside the database's lock, then swaps
// them in under the exclusive lock after saving them, like any other write.

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "server/common/stopwatch.h"
#include "server/crossing/features.h"
#include "server/crossing/view_database.h"
#include "server/service/crossing/crossing_database.h"
#include "server/service/crossing/folder.h"
#include "server/service/crossing/global_stage.h"
#include "server/service/crossing/params.h"
#include "server/service/runtime/work_gate.h"
#include "storage/crossing_store.h"
#include "waymark/v1/crossing.pb.h"

namespace waymark::service {

// How many feature extractions (recognitions and enrollments) run at once, and how many may wait
// for a turn before the next request gets RESOURCE_EXHAUSTED (work_gate.h).
struct ExtractionLimits {
  int max_running = 0;   // 0 = the machine's hardware threads
  int max_waiting = -1;  // -1 = 32 per running extraction (about 1 s of waiting at 30 ms each)
};

class CrossingRegistry {
 public:
  // Loads every database of `store` into memory.
  static absl::StatusOr<std::unique_ptr<CrossingRegistry>> Load(
      std::unique_ptr<storage::CrossingStore> store, const crossing::IndexOptions& index = {},
      const ExtractionLimits& limits = {});

  absl::StatusOr<v1::CrossingDatabase> CreateDatabase(const v1::CreateDatabaseRequest& request);
  absl::StatusOr<v1::ListDatabasesResponse> ListDatabases();
  absl::Status DeleteDatabase(const std::string& name);
  absl::StatusOr<v1::DatabaseStats> GetStats(const std::string& name);

  absl::StatusOr<v1::Crossing> AddCrossing(const v1::AddCrossingRequest& request);
  absl::StatusOr<v1::ListCrossingsResponse> ListCrossings(const std::string& database);
  absl::StatusOr<v1::DeleteCrossingResponse> DeleteCrossing(const v1::DeleteCrossingRequest& r);

  // Stores a view (outcome STORED), or answers DUPLICATE naming the view that already holds the
  // same image (SHA-256 of the encoded bytes). The check is made before extraction (a re-run over
  // a folder already enrolled costs a hash per view) and again under the exclusive lock, in the
  // same critical section as the commit, so concurrent enrollments of one image store it once.
  // With request.replace(), see crossing.proto. Implemented in crossing_enrollment.cc.
  // `crossing_created`, if given, is set when the request created its crossing.
  absl::StatusOr<v1::EnrollViewResponse> EnrollView(const v1::EnrollViewRequest& request,
                                                    bool* crossing_created = nullptr);
  // EnrollView in its two steps, so that a stream of views can extract the next views' features
  // while one commits (BulkEnroll, StreamEnroll). PrepareEnrollment needs no exclusive lock: it
  // validates, hashes, answers a duplicate already held and extracts the features.
  // CommitEnrollment takes the lock and does the rest as EnrollView (the checks again, the
  // cluster, the transaction, memory). A prepared view carries no database state, so views of one
  // stream may be prepared out of order and committed in order.
  struct PreparedEnrollment {
    Clock::time_point start;
    std::string content;  // SHA-256 of the image bytes
    crossing::ExtractionTimings timings;
    crossing::ImageFeatures features;
    std::optional<PreparedGlobal> global;  // when the database keeps a global descriptor
    std::optional<v1::EnrollViewResponse> answer;  // set when nothing is left to commit
  };
  absl::StatusOr<PreparedEnrollment> PrepareEnrollment(const v1::EnrollViewRequest& request);
  absl::StatusOr<v1::EnrollViewResponse> CommitEnrollment(const v1::EnrollViewRequest& request,
                                                          PreparedEnrollment prepared,
                                                          bool* crossing_created = nullptr);
  absl::StatusOr<v1::RebuildClustersResponse> RebuildClusters(
      const v1::RebuildClustersRequest& request);

  // `effective`, if given, gets the options the request resolved to (the database's defaults
  // under the request's overrides).
  absl::StatusOr<v1::RecognizeResponse> Recognize(
      const v1::RecognizeRequest& request, crossing::RecognitionOptions* effective = nullptr);

  // Brings memory up to what the store holds when other servers share it (PostgreSQL,
  // docs/scale-out.md): databases created or deleted elsewhere, and every database another
  // server changed (crossing_loading.h, CatchUp). A server runs it when the store tells of a
  // change and every few seconds (CrossingFleetSync); a no-op on a store nobody shares.
  absl::Status Sync();
  // Whether the store is shared with other servers.
  bool shared() const { return store_->shared(); }
  // The store's change feed (nullptr when not shared), for CrossingFleetSync.
  absl::StatusOr<std::unique_ptr<storage::ChangeFeed>> WatchChanges() {
    return store_->WatchChanges();
  }

  // Sees every answer Recognize gives (unary and streamed, before a stream's evidence is applied),
  // on the caller's thread with the database's reader lock held: it must only copy what it needs
  // and return (the live view, server/service/live/). Null (the default) = none.
  using RecognitionObserver =
      std::function<void(const std::string& database, const v1::RecognizeResponse& response)>;
  void SetRecognitionObserver(RecognitionObserver observer);

  // Blocks until the global stage's background work (vocabularies, codes; global_stage.h) is
  // done for every database: for tests, benchmarks and evaluations that need a settled state.
  void WaitForGlobalStage() { global_worker_->WaitIdle(); }

 private:
  using Database = ResidentDatabase;
  // What a commit of a new view did, for the answer (crossing_enrollment.cc).
  struct CommittedView;

  CrossingRegistry(std::unique_ptr<storage::CrossingStore> store,
                   const crossing::IndexOptions& index, const ExtractionLimits& limits);

  // crossing::ExtractFeatures behind the extraction gate.
  absl::StatusOr<crossing::ImageFeatures> Extract(const std::string& encoded,
                                                  const crossing::FeatureOptions& options,
                                                  crossing::ExtractionTimings* timings);

  // The two ways an enrollment commits, both with db.mutex held exclusively: a plain insert, and
  // one that replaces the views for which `replaced` is true (re-clustering the rest).
  absl::StatusOr<CommittedView> CommitView(Database& db, const v1::EnrollViewRequest& request,
                                           const storage::ViewRecord& record,
                                           const PreparedEnrollment& prepared, bool new_crossing);
  absl::StatusOr<CommittedView> CommitReplacingViews(
      Database& db, const v1::EnrollViewRequest& request, const storage::ViewRecord& record,
      const PreparedEnrollment& prepared, bool new_crossing,
      const std::function<bool(const crossing::ViewEntry&)>& replaced);

  absl::StatusOr<std::shared_ptr<Database>> Find(const std::string& name);
  // The API view of a database (caller holds its lock).
  static v1::CrossingDatabase Describe(const Database& db);

  std::unique_ptr<storage::CrossingStore> store_;
  crossing::IndexOptions index_options_;
  WorkGate extraction_gate_;
  absl::Mutex mutex_;  // guards databases_ (the map, not the databases)
  std::map<std::string, std::shared_ptr<Database>> databases_;
  void NotifyRecognition(const std::string& database, const v1::RecognizeResponse& response);
  absl::Mutex observer_mutex_;  // guards recognition_observer_ (copied out, called unlocked)
  std::shared_ptr<const RecognitionObserver> recognition_observer_;
  // Last: destroyed first, while the store and the databases it works on still exist.
  std::unique_ptr<GlobalStageWorker> global_worker_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_REGISTRY_H_
