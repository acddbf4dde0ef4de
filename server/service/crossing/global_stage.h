#ifndef WAYMARK_SERVER_SERVICE_CROSSING_GLOBAL_STAGE_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_GLOBAL_STAGE_H_

// The retrieval mode's global stage of the resident crossing databases (issue 18): a database
// that keeps a global descriptor (DatabaseParams.global_descriptor) learns a VLAD vocabulary from
// its own views and holds a code of every view under it (server/crossing/vlad.h, global_index.h).
//
// Why each database learns its own vocabulary, and when. A vocabulary learnt on a third of a set's
// views lost 25-30 points of top-1 on the triplets against one learnt on all of them
// (docs/results.md), so one fixed vocabulary would not do. The first is learnt when the database
// holds kFirstVocabularyViews views, then again each time the count reaches the next power-of-two
// multiple of it (32, 64, ...), up to kLastVocabularyViews; after that it stays. Each retraining recomputes every view's code (a dense
// extraction per view), so all of them together cost at most the dense extractions of
// 2 x kLastVocabularyViews views, whatever the database grows to.
//
// How, without stopping recognition. The worker thread learns the words from the samples held in
// memory (ViewEntry::global_sample: kVocabularySampleRows dense descriptors per view, dropped
// after the last retraining), recomputes each view's code from its stored working image
// outside the database's lock, saves the vocabulary and the codes in one transaction, and only
// then installs both under the exclusive lock (disk first, as every write of the registry).
// Views enrolled meanwhile got a code of the old vocabulary or none: they are `uncoded` and the
// worker codes them in its next round. An enrollment under a settled vocabulary codes its own view
// (PrepareGlobal, outside the lock; InstallGlobal at the commit). Until a database has its first
// vocabulary, the retrieval mode runs without the global stage.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "server/crossing/features.h"
#include "server/crossing/global_index.h"
#include "server/service/crossing/crossing_database.h"
#include "server/service/crossing/folder.h"
#include "storage/crossing_store.h"

namespace waymark::service {

inline constexpr int kFirstVocabularyViews = 16;
inline constexpr int kLastVocabularyViews = 512;

// Whether a database of `views` views, with a vocabulary learnt from `trained_views` (0: none),
// should learn a new one.
bool NeedsVocabulary(int views, int trained_views);

// Whether views keep their samples (ViewEntry::global_sample, view.global_sample): until the
// last vocabulary is learnt (caller holds db's lock).
bool KeepsSamples(const ResidentDatabase& db);

// Whether the worker has something to do for `db` (caller holds its lock).
bool GlobalStageHasWork(const ResidentDatabase& db);

// What an enrollment computes for the global stage from the view's features, outside the lock.
struct PreparedGlobal {
  std::string work_image;   // the grey working image, PNG
  cv::Mat sample;           // EvenRows of the dense descriptors
  uint64_t vocabulary = 0;  // the vocabulary `code` was computed under; 0 = no code
  crossing::GlobalCode code;
};
// `features` extracted with FeatureOptions::global_descriptor. Takes db's reader lock to read its
// vocabulary. INTERNAL if the working image cannot be encoded.
absl::StatusOr<PreparedGlobal> PrepareGlobal(const ResidentDatabase& db,
                                             const crossing::ImageFeatures& features);
// Under db's exclusive lock, before the view is stored: its work image, sample and (when still
// current) code go into `record`.
void FillGlobalRecord(const ResidentDatabase& db, const PreparedGlobal& prepared,
                      storage::ViewRecord* record);
// Under db's exclusive lock, after the view `view_id` was installed in `slot`.
void InstallGlobal(ResidentDatabase& db, uint32_t slot, int64_t view_id,
                   const PreparedGlobal& prepared);

// Loading a database: its stored vocabulary (before the views; a vocabulary that does not parse is
// dropped with a warning and learnt again), then each view's stored sample and code.
void LoadGlobalVocabulary(ResidentDatabase& db,
                          const std::optional<storage::VocabularyRecord>& record);
void LoadGlobalView(ResidentDatabase& db, uint32_t slot, const storage::ViewRecord& view);

// One background thread that trains vocabularies and codes views, database after database.
class GlobalStageWorker {
 public:
  // `index`: how the registry indexes views, for catching a shared database up before a save.
  GlobalStageWorker(storage::CrossingStore* store, const crossing::IndexOptions& index);
  ~GlobalStageWorker();  // stops (a round in progress is abandoned) and joins
  GlobalStageWorker(const GlobalStageWorker&) = delete;
  GlobalStageWorker& operator=(const GlobalStageWorker&) = delete;

  // Queues `db`; the worker looks whether it has work. Takes no lock of db, so an enrollment
  // calls it from its commit.
  void Schedule(const std::shared_ptr<ResidentDatabase>& db);
  // Blocks until no database is queued or worked on (tests, benchmarks, evaluation runs).
  void WaitIdle();

 private:
  void Loop();
  // One training or coding round; false when it changed nothing (no work, or it failed).
  bool Round(ResidentDatabase& db);

  storage::CrossingStore* store_;
  const crossing::IndexOptions index_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::shared_ptr<ResidentDatabase>> queue_;
  // Databases queued or being worked on -> whether they were scheduled again meanwhile.
  std::map<const ResidentDatabase*, bool> pending_;
  std::atomic<bool> stopping_{false};  // written under mutex_, read by rounds without it
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_GLOBAL_STAGE_H_
