#include "server/service/crossing/crossing_registry.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <thread>
#include <unordered_map>

#include "absl/strings/str_cat.h"
#include "server/common/input_bounds.h"
#include "server/common/quote.h"
#include "server/common/stopwatch.h"
#include "server/crossing/features.h"
#include "server/crossing/recognizer.h"
#include "server/service/crossing/crossing_database.h"
#include "server/service/crossing/crossing_loading.h"

namespace waymark::service {
namespace {

using crossing::ViewDatabase;

absl::Status ValidateDatabaseName(const std::string& name) {
  if (name.empty() || name.size() > 64) {
    return absl::InvalidArgumentError(
        absl::StrCat("database name ", QuoteClientText(name), " must be 1-64 characters long"));
  }
  for (char c : name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) {
      return absl::InvalidArgumentError(absl::StrCat(
          "database name ", QuoteClientText(name),
          " may contain only letters, digits, '-', '_' and '.'"));
    }
  }
  return absl::OkStatus();
}

// Waiting extractions allowed per running one: about 1 s of queue at 30 ms per extraction.
constexpr int kWaitingPerRunning = 32;

int MaxRunning(const ExtractionLimits& limits) {
  if (limits.max_running > 0) return limits.max_running;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// Why a retrieval-mode answer ran without its global stage (RecognizeResponse
// .global_stage_skipped): the database's lack before the query's. "" when it ran or the mode has
// none. Requires db.mutex.
const char* GlobalStageSkipped(const ResidentDatabase& db, const crossing::ImageFeatures& query,
                               const crossing::Recognition& result) {
  if (result.mode != crossing::RecognitionMode::kRetrieval || result.global_stage) return "";
  if (!db.options.features.global_descriptor) return "off";
  if (db.global.vocabulary == 0) return "no_vocabulary";
  if (query.descriptors.rows == 0) return "no_keypoints";
  if (query.dense.empty()) return "no_dense";
  return "not_coded";
}

}  // namespace

CrossingRegistry::CrossingRegistry(std::unique_ptr<storage::CrossingStore> store,
                                   const crossing::IndexOptions& index,
                                   const ExtractionLimits& limits)
    : store_(std::move(store)),
      index_options_(index),
      extraction_gate_(MaxRunning(limits), limits.max_waiting >= 0
                                               ? limits.max_waiting
                                               : kWaitingPerRunning * MaxRunning(limits)),
      global_worker_(std::make_unique<GlobalStageWorker>(store_.get(), index)) {}

absl::StatusOr<crossing::ImageFeatures> CrossingRegistry::Extract(
    const std::string& encoded, const crossing::FeatureOptions& options,
    crossing::ExtractionTimings* timings) {
  absl::StatusOr<WorkGate::Turn> turn = extraction_gate_.Enter("feature extractions");
  if (!turn.ok()) return turn.status();
  return crossing::ExtractFeatures(encoded, options, timings);
}

absl::StatusOr<std::unique_ptr<CrossingRegistry>> CrossingRegistry::Load(
    std::unique_ptr<storage::CrossingStore> store, const crossing::IndexOptions& index,
    const ExtractionLimits& limits) {
  std::unique_ptr<CrossingRegistry> registry(new CrossingRegistry(std::move(store), index, limits));
  absl::StatusOr<std::vector<storage::DatabaseRecord>> records = registry->store_->ListDatabases();
  if (!records.ok()) return records.status();
  for (const auto& record : *records) {
    absl::StatusOr<std::shared_ptr<Database>> db =
        LoadResidentDatabase(*registry->store_, registry->index_options_, record);
    if (!db.ok()) {
      return absl::Status(db.status().code(), absl::StrCat("loading database \"", record.name,
                                                           "\": ", db.status().message()));
    }
    registry->databases_[record.name] = *db;
    registry->global_worker_->Schedule(*db);  // codes of an older vocabulary, a due retraining
  }
  return registry;
}

absl::Status CrossingRegistry::Sync() {
  if (!store_->shared()) return absl::OkStatus();
  absl::StatusOr<std::vector<storage::DatabaseRecord>> records = store_->ListDatabases();
  if (!records.ok()) return records.status();
  std::map<std::string, storage::DatabaseRecord> stored;
  for (auto& record : *records) stored[record.name] = std::move(record);

  // What memory holds that the list did not (or held under another id: deleted and created again
  // elsewhere), and what to catch up.
  std::vector<std::shared_ptr<Database>> changed, missing;
  {
    absl::ReaderMutexLock lock(&mutex_);
    for (const auto& [name, db] : databases_) {
      auto found = stored.find(name);
      absl::ReaderMutexLock db_lock(&db->mutex);
      if (found == stored.end() || found->second.id != db->record.id) {
        missing.push_back(db);
      } else if (found->second.revision != db->record.revision ||
                 found->second.reload_revision != db->record.reload_revision) {
        changed.push_back(db);
      }
    }
  }
  absl::Status result;
  // A database this server created after the list was read is missing from it too: only what
  // the store says now is gone is dropped.
  for (const auto& db : missing) {
    absl::StatusOr<storage::DatabaseRecord> now = store_->GetDatabase(db->record.name);
    if (now.ok() && now->id == db->record.id) continue;
    if (!now.ok() && !absl::IsNotFound(now.status())) {
      result = now.status();
      continue;
    }
    absl::MutexLock lock(&mutex_);
    auto it = databases_.find(db->record.name);
    if (it == databases_.end() || it->second != db) continue;
    absl::MutexLock db_lock(&db->mutex);
    db->deleted = true;  // requests that hold it get NOT_FOUND
    databases_.erase(it);
  }
  for (const auto& db : changed) {
    const absl::Status caught_up = CatchUp(*store_, index_options_, *db);
    if (!caught_up.ok() && !absl::IsNotFound(caught_up)) result = caught_up;
    global_worker_->Schedule(db);  // a vocabulary may be due, or codes of new views
  }
  // Databases created elsewhere, loaded outside the map's lock.
  for (const auto& [name, record] : stored) {
    {
      absl::ReaderMutexLock lock(&mutex_);
      if (databases_.count(name)) continue;
    }
    absl::StatusOr<std::shared_ptr<Database>> db =
        LoadResidentDatabase(*store_, index_options_, record);
    if (!db.ok()) {
      if (!absl::IsNotFound(db.status())) result = db.status();
      continue;
    }
    // Deleted (here or elsewhere) while it was loading: not installed.
    absl::StatusOr<storage::DatabaseRecord> now = store_->GetDatabase(name);
    if (!now.ok() || now->id != record.id) continue;
    absl::MutexLock lock(&mutex_);
    if (databases_.emplace(name, *db).second) global_worker_->Schedule(*db);
  }
  return result;
}

absl::StatusOr<std::shared_ptr<CrossingRegistry::Database>> CrossingRegistry::Find(
    const std::string& name) {
  absl::ReaderMutexLock lock(&mutex_);
  auto it = databases_.find(name);
  if (it == databases_.end()) {
    return absl::NotFoundError(absl::StrCat("database ", QuoteClientText(name),
                                            " not found: create it with `waymark db create`"));
  }
  return it->second;
}

v1::CrossingDatabase CrossingRegistry::Describe(const Database& db) {
  v1::CrossingDatabase out;
  out.set_id(db.record.id);
  out.set_name(db.record.name);
  *out.mutable_params() = db.params;
  out.set_created_at(db.record.created_at);
  out.set_crossings(static_cast<int32_t>(db.crossings.size()));
  out.set_views(static_cast<int32_t>(db.views->views().size()));
  out.set_clusters(static_cast<int32_t>(db.views->clusters().size()));
  return out;
}

absl::StatusOr<v1::CrossingDatabase> CrossingRegistry::CreateDatabase(
    const v1::CreateDatabaseRequest& request) {
  if (absl::Status s = ValidateDatabaseName(request.name()); !s.ok()) return s;
  absl::StatusOr<v1::DatabaseParams> params = EffectiveDatabaseParams(request.params());
  if (!params.ok()) return params.status();
  absl::MutexLock lock(&mutex_);
  if (databases_.count(request.name())) {
    return absl::AlreadyExistsError(
        absl::StrCat("database ", QuoteClientText(request.name()), " already exists"));
  }
  absl::StatusOr<storage::DatabaseRecord> record =
      store_->CreateDatabase(request.name(), ParamsToJson(*params));
  if (!record.ok()) return record.status();
  auto db = std::make_shared<Database>();
  db->record = *record;
  db->params = *params;
  db->options = ToDatabaseOptions(*params);
  db->views = std::make_unique<ViewDatabase>(index_options_);
  databases_[request.name()] = db;
  return Describe(*db);
}

absl::StatusOr<v1::ListDatabasesResponse> CrossingRegistry::ListDatabases() {
  std::vector<std::shared_ptr<Database>> all;
  {
    absl::ReaderMutexLock lock(&mutex_);
    for (const auto& [name, db] : databases_) all.push_back(db);
  }
  v1::ListDatabasesResponse response;
  for (const auto& db : all) {
    absl::ReaderMutexLock lock(&db->mutex);
    *response.add_databases() = Describe(*db);
  }
  return response;
}

absl::Status CrossingRegistry::DeleteDatabase(const std::string& name) {
  absl::MutexLock lock(&mutex_);
  auto it = databases_.find(name);
  if (it == databases_.end()) {
    return absl::NotFoundError(absl::StrCat("database ", QuoteClientText(name), " not found"));
  }
  // The database must outlive its lock: erasing the map's entry may drop the last reference,
  // and a mutex destroyed while held is undefined behaviour (absl aborts on it in debug checks).
  const std::shared_ptr<Database> db = it->second;
  absl::MutexLock db_lock(&db->mutex);
  if (absl::Status s = store_->DeleteDatabase(name); !s.ok()) return s;
  db->deleted = true;
  databases_.erase(it);
  return absl::OkStatus();
}

absl::StatusOr<v1::DatabaseStats> CrossingRegistry::GetStats(const std::string& name) {
  absl::StatusOr<std::shared_ptr<Database>> found = Find(name);
  if (!found.ok()) return found.status();
  const Database& db = **found;
  absl::ReaderMutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  v1::DatabaseStats stats;
  *stats.mutable_database() = Describe(db);
  stats.set_keypoints(db.keypoints);
  stats.set_descriptor_bytes(db.keypoints * crossing::kDescriptorSize);
  stats.set_vocabulary_views(db.global.trained_views);
  stats.set_coded_views(static_cast<int32_t>(db.views->global_index().coded()));
  for (const auto& c : db.views->clusters()) {
    v1::ClusterInfo* info = stats.add_clusters();
    info->set_id(c.cluster_id);
    info->set_center_view_id(db.views->views()[c.center].view_id);
    info->set_members(static_cast<int32_t>(c.members.size()));
  }
  for (const auto& [id, c] : db.crossings) {
    v1::Crossing* out = stats.add_crossing_list();
    out->set_id(id);
    out->set_name(c.name);
    out->set_label(c.label);
    auto n = db.views_per_crossing.find(id);
    out->set_views(n == db.views_per_crossing.end() ? 0 : n->second);
  }
  return stats;
}

absl::StatusOr<v1::Crossing> CrossingRegistry::AddCrossing(const v1::AddCrossingRequest& request) {
  if (absl::Status s = ValidateCrossingName(request.name()); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;
  absl::StatusOr<WriteScope> writing = WriteScope::Begin(*store_, index_options_, db);
  if (!writing.ok()) return writing.status();
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  if (db.crossing_ids.count(request.name())) {
    return absl::AlreadyExistsError(absl::StrCat("crossing ", QuoteClientText(request.name()),
                                                 " already exists in database ",
                                                 QuoteClientText(request.database())));
  }
  absl::StatusOr<storage::CrossingRecord> record =
      store_->AddCrossing(db.record.id, request.name(), request.label());
  if (!record.ok()) return record.status();
  db.NoteOwnWrite(/*reload=*/false);
  db.AddCrossingRecord(*record);
  v1::Crossing out;
  out.set_id(record->id);
  out.set_name(record->name);
  out.set_label(record->label);
  return out;
}

absl::StatusOr<v1::ListCrossingsResponse> CrossingRegistry::ListCrossings(
    const std::string& database) {
  absl::StatusOr<v1::DatabaseStats> stats = GetStats(database);
  if (!stats.ok()) return stats.status();
  v1::ListCrossingsResponse response;
  *response.mutable_crossings() = stats->crossing_list();
  return response;
}

absl::StatusOr<v1::DeleteCrossingResponse> CrossingRegistry::DeleteCrossing(
    const v1::DeleteCrossingRequest& request) {
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;
  absl::StatusOr<WriteScope> writing = WriteScope::Begin(*store_, index_options_, db);
  if (!writing.ok()) return writing.status();
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  auto id_it = db.crossing_ids.find(request.name());
  if (id_it == db.crossing_ids.end()) {
    return absl::NotFoundError(absl::StrCat("crossing ", QuoteClientText(request.name()),
                                            " not found in database ",
                                            QuoteClientText(request.database())));
  }
  const int64_t crossing_id = id_it->second;
  // The remaining views, re-clustered in enrollment order, become the new memory and disk state
  // in one transaction.
  RemainingViews remaining = CopyViewsExcept(
      *db.views, [&](const crossing::ViewEntry& v) { return v.crossing_id == crossing_id; },
      index_options_);
  const auto clusters = remaining.views->ComputeClusters(db.options.clustering);
  absl::StatusOr<int> deleted = store_->DeleteCrossing(
      db.record.id, crossing_id, Database::ToRecords(*remaining.views, clusters));
  if (!deleted.ok()) return deleted.status();
  db.NoteOwnWrite(/*reload=*/true);
  absl::StatusOr<std::vector<storage::ClusterRecord>> stored = store_->LoadClusters(db.record.id);
  if (!stored.ok()) return stored.status();
  Database::InstallClusters(*stored, remaining.views.get());
  db.views = std::move(remaining.views);
  db.keypoints = remaining.keypoints;
  for (int64_t view_id : remaining.dropped_view_ids) db.contents.Remove(view_id);
  db.crossings.erase(crossing_id);
  db.crossing_ids.erase(id_it);
  db.views_per_crossing.erase(crossing_id);
  v1::DeleteCrossingResponse response;
  response.set_views_deleted(*deleted);
  return response;
}

absl::StatusOr<v1::RebuildClustersResponse> CrossingRegistry::RebuildClusters(
    const v1::RebuildClustersRequest& request) {
  const auto start = Clock::now();
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;
  absl::StatusOr<WriteScope> writing = WriteScope::Begin(*store_, index_options_, db);
  if (!writing.ok()) return writing.status();
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  crossing::ClusterOptions options = db.options.clustering;
  v1::DatabaseParams params = db.params;
  if (request.has_cluster_threshold()) {
    options.threshold = request.cluster_threshold();
    if (absl::Status s = crossing::ValidateClusterOptions(options); !s.ok()) return s;
    params.set_cluster_threshold(options.threshold);
  }
  const auto clusters = db.views->ComputeClusters(options);
  absl::StatusOr<std::vector<storage::ClusterRecord>> stored =
      store_->ReplaceClusters(db.record.id, Database::ToRecords(*db.views, clusters));
  if (!stored.ok()) return stored.status();
  db.NoteOwnWrite(/*reload=*/true);
  Database::InstallClusters(*stored, db.views.get());
  if (request.has_cluster_threshold()) {
    const std::string json = ParamsToJson(params);
    if (absl::Status s = store_->UpdateDatabaseParams(db.record.id, json); !s.ok()) return s;
    db.NoteOwnWrite(/*reload=*/true);
    db.record.params = json;
    db.params = params;
    db.options.clustering = options;
  }
  v1::RebuildClustersResponse response;
  response.set_clusters(static_cast<int32_t>(clusters.size()));
  response.set_views(static_cast<int32_t>(db.views->views().size()));
  response.set_elapsed_ms(MsSince(start));
  return response;
}

void CrossingRegistry::SetRecognitionObserver(RecognitionObserver observer) {
  absl::MutexLock lock(&observer_mutex_);
  recognition_observer_ =
      observer ? std::make_shared<const RecognitionObserver>(std::move(observer)) : nullptr;
}

void CrossingRegistry::NotifyRecognition(const std::string& database,
                                         const v1::RecognizeResponse& response) {
  std::shared_ptr<const RecognitionObserver> observer;
  {
    absl::MutexLock lock(&observer_mutex_);
    observer = recognition_observer_;
  }
  if (observer) (*observer)(database, response);
}

absl::StatusOr<v1::RecognizeResponse> CrossingRegistry::Recognize(
    const v1::RecognizeRequest& request, crossing::RecognitionOptions* effective) {
  const auto start = Clock::now();
  // The stamp is echoed in the answer: a NaN or infinite one would leave the server (the issue 21
  // campaign saw 18 such answers).
  if (!PlausibleStamp(request.image().stamp())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image stamp ", request.image().stamp(), " s is not a time (finite, |stamp| <= ",
        kMaxAbsStampS, "; 0 = none)"));
  }
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  const Database& db = **found;
  absl::StatusOr<crossing::RecognitionOptions> options =
      ResolveRecognitionOptions(db.options.recognition, request.params());
  if (!options.ok()) return options.status();
  if (effective != nullptr) *effective = *options;

  // The dense descriptors only when the global stage will use them.
  crossing::FeatureOptions feature_options = db.options.features;
  if (options->mode != crossing::RecognitionMode::kRetrieval) {
    feature_options.global_descriptor = false;
  } else if (feature_options.global_descriptor) {
    absl::ReaderMutexLock lock(&db.mutex);
    feature_options.global_descriptor = db.global.vocabulary != 0;
  }
  crossing::ExtractionTimings timings;
  absl::StatusOr<crossing::ImageFeatures> features =
      Extract(request.image().data(), feature_options, &timings);
  if (!features.ok()) return features.status();

  absl::ReaderMutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  absl::StatusOr<crossing::Recognition> result =
      crossing::Recognize(*db.views, *features, *options);
  if (!result.ok()) return result.status();

  v1::RecognizeResponse response;
  const auto& views = db.views->views();
  response.set_recognized(result->recognized);
  if (result->recognized) {
    const crossing::ViewEntry& best = views[result->best_slot];
    response.set_crossing_id(best.crossing_id);
    response.set_crossing(db.CrossingName(best.crossing_id));
    response.set_view_id(best.view_id);
    response.set_heading_deg(best.heading_deg);
    response.set_position(best.position);
  }
  response.set_decision(result->decision);
  response.set_log10_nfa(result->log10_nfa);
  response.set_global_lift(result->global_lift);
  response.set_accepted_by_global(result->accepted_by_global);
  response.set_accepted_by(crossing::AcceptedByName(result->accepted_by));
  response.set_nfa_computed(result->nfa_computed);
  response.set_global_stage(result->global_stage);
  response.set_global_stage_skipped(GlobalStageSkipped(db, *features, *result));
  if (result->global_stage) {
    const crossing::ViewEntry& top = views[result->global.best_slot];
    response.set_global_model(result->global.computed);
    response.set_global_crossing_id(top.crossing_id);
    response.set_global_crossing(db.CrossingName(top.crossing_id));
    response.set_global_view_id(top.view_id);
    response.set_global_similarity(result->global.best_similarity);
    if (result->global.computed) {
      response.set_global_log10_false_alarms(result->global.log10_efa);
    }
  }
  for (const crossing::Candidate& c : result->candidates) {
    const crossing::ViewEntry& v = views[c.slot];
    v1::Candidate* out = response.add_candidates();
    out->set_view_id(v.view_id);
    out->set_crossing_id(v.crossing_id);
    out->set_crossing(db.CrossingName(v.crossing_id));
    out->set_heading_deg(v.heading_deg);
    out->set_position(v.position);
    if (v.cluster >= 0) out->set_cluster_id(db.views->clusters()[v.cluster].cluster_id);
    out->set_is_center(c.is_center);
    out->set_matches(c.matches);
    out->set_tentative(c.tentative);
    out->set_similarity(c.similarity);
    out->set_decision(c.decision);
    out->set_kept(c.kept);
    out->set_log10_nfa(c.log10_nfa);
    out->set_global_similarity(c.global_similarity);
  }
  response.set_keypoints(features->descriptors.rows);
  response.set_qualifying_clusters(result->qualifying_clusters);
  response.set_mode(ToProtoMode(result->mode));
  response.set_reason(result->reason);
  response.set_stamp(request.image().stamp());
  v1::StageTimings* t = response.mutable_timings();
  t->set_decode_ms(timings.decode_ms);
  t->set_extraction_ms(timings.extraction_ms);
  t->set_matching_ms(result->matching_ms);
  t->set_histogram_ms(timings.histogram_ms + result->histogram_ms);
  t->set_verification_ms(result->verification_ms);
  t->set_retrieval_ms(timings.dense_ms + result->retrieval_ms);
  t->set_total_ms(MsSince(start));
  NotifyRecognition(request.database(), response);
  return response;
}

}  // namespace waymark::service
