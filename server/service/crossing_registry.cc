#include "server/service/crossing_registry.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <thread>
#include <unordered_map>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/crossing/features.h"
#include "server/crossing/recognizer.h"

namespace waymark::service {
namespace {

using crossing::ViewDatabase;

// A view with fewer keypoints could never reach N1 = 10 matches: refuse it at enrollment.
constexpr int kMinEnrollKeypoints = 10;

absl::Status ValidateDatabaseName(const std::string& name) {
  if (name.empty() || name.size() > 64) {
    return absl::InvalidArgumentError(
        absl::StrCat("database name \"", name, "\" must be 1-64 characters long"));
  }
  for (char c : name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) {
      return absl::InvalidArgumentError(absl::StrCat(
          "database name \"", name, "\" may contain only letters, digits, '-', '_' and '.'"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateCrossingName(const std::string& name) {
  if (name.empty() || name.size() > 128) {
    return absl::InvalidArgumentError(
        absl::StrCat("crossing name \"", name, "\" must be 1-128 characters long"));
  }
  for (char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == '/') {
      return absl::InvalidArgumentError(absl::StrCat(
          "crossing name \"", name, "\" may not contain '/' or control characters"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateHeading(double heading) {
  if (!std::isfinite(heading) || heading < 0 || heading >= 360) {
    return absl::InvalidArgumentError(
        absl::StrCat("heading_deg = ", heading, " is outside [0, 360): give the view's compass "
                     "heading in degrees, clockwise"));
  }
  return absl::OkStatus();
}

storage::ViewRecord ToRecord(int64_t crossing_id, double heading,
                             const crossing::ImageFeatures& f) {
  storage::ViewRecord r;
  r.crossing_id = crossing_id;
  r.heading_deg = heading;
  r.width = f.width;
  r.height = f.height;
  r.keypoint_count = static_cast<int32_t>(f.keypoints.size());
  r.keypoints.reserve(f.keypoints.size() * storage::kKeypointFloats);
  for (const cv::KeyPoint& kp : f.keypoints) {
    r.keypoints.insert(r.keypoints.end(), {kp.pt.x, kp.pt.y, kp.size, kp.angle, kp.response,
                                           static_cast<float>(kp.octave)});
  }
  r.descriptors.assign(f.descriptors.datastart, f.descriptors.dataend);
  r.hue_hist = f.hue_hist;
  return r;
}

}  // namespace

struct CrossingRegistry::Database {
  storage::DatabaseRecord record;
  v1::DatabaseParams params;  // effective values
  DatabaseOptions options;
  std::unique_ptr<ViewDatabase> views;
  std::map<int64_t, storage::CrossingRecord> crossings;  // by id
  std::map<std::string, int64_t> crossing_ids;           // by name
  std::map<int64_t, int> views_per_crossing;
  int64_t keypoints = 0;
  bool deleted = false;  // requests that still hold a pointer get NOT_FOUND
  mutable absl::Mutex mutex;

  absl::Status CheckAlive() const {
    if (deleted) return absl::NotFoundError(absl::StrCat("database \"", record.name, "\" was deleted"));
    return absl::OkStatus();
  }
  void AddCrossingRecord(const storage::CrossingRecord& c) {
    crossings[c.id] = c;
    crossing_ids[c.name] = c.id;
  }
  // Installs clusters given as storage records (view ids) into `target`.
  static void InstallClusters(const std::vector<storage::ClusterRecord>& records,
                              ViewDatabase* target) {
    std::unordered_map<int64_t, uint32_t> slot_of;
    for (uint32_t s = 0; s < target->views().size(); ++s) slot_of[target->views()[s].view_id] = s;
    std::vector<crossing::ClusterEntry> clusters;
    for (const auto& r : records) {
      crossing::ClusterEntry c;
      c.cluster_id = r.id;
      c.center = slot_of.at(r.center_view_id);
      c.members.push_back(c.center);
      for (int64_t v : r.member_view_ids) {
        if (v != r.center_view_id) c.members.push_back(slot_of.at(v));
      }
      clusters.push_back(std::move(c));
    }
    target->SetClusters(std::move(clusters));
  }
  // Clusters of `source` (slots) as storage records (view ids).
  static std::vector<storage::ClusterRecord> ToRecords(
      const ViewDatabase& source, const std::vector<crossing::ClusterEntry>& clusters) {
    std::vector<storage::ClusterRecord> records;
    for (const auto& c : clusters) {
      storage::ClusterRecord r;
      r.center_view_id = source.views()[c.center].view_id;
      for (uint32_t s : c.members) r.member_view_ids.push_back(source.views()[s].view_id);
      records.push_back(std::move(r));
    }
    return records;
  }
};

namespace {

// Waiting extractions allowed per running one: about 1 s of queue at 30 ms per extraction.
constexpr int kWaitingPerRunning = 32;

int MaxRunning(const ExtractionLimits& limits) {
  if (limits.max_running > 0) return limits.max_running;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

}  // namespace

CrossingRegistry::CrossingRegistry(std::unique_ptr<storage::CrossingStore> store,
                                   const crossing::IndexOptions& index,
                                   const ExtractionLimits& limits)
    : store_(std::move(store)),
      index_options_(index),
      extraction_gate_(MaxRunning(limits), limits.max_waiting >= 0
                                               ? limits.max_waiting
                                               : kWaitingPerRunning * MaxRunning(limits)) {}

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
    absl::StatusOr<std::shared_ptr<Database>> db = registry->LoadDatabase(record);
    if (!db.ok()) {
      return absl::Status(db.status().code(), absl::StrCat("loading database \"", record.name,
                                                           "\": ", db.status().message()));
    }
    registry->databases_[record.name] = *db;
  }
  return registry;
}

absl::StatusOr<std::shared_ptr<CrossingRegistry::Database>> CrossingRegistry::LoadDatabase(
    const storage::DatabaseRecord& record) {
  auto db = std::make_shared<Database>();
  db->record = record;
  absl::StatusOr<v1::DatabaseParams> params = ParamsFromJson(record.params);
  if (!params.ok()) return params.status();
  db->params = *params;
  db->options = ToDatabaseOptions(db->params);
  db->views = std::make_unique<ViewDatabase>(index_options_);

  absl::StatusOr<std::vector<storage::CrossingRecord>> crossings =
      store_->ListCrossings(record.id);
  if (!crossings.ok()) return crossings.status();
  for (const auto& c : *crossings) db->AddCrossingRecord(c);

  // One view at a time: a large database never sits in memory twice (rows and index).
  const absl::Status loaded = store_->ForEachView(record.id, [&](storage::ViewRecord&& v) {
    if (v.format_version != storage::kFeatureFormatVersion ||
        v.width != db->options.features.work_width ||
        v.height != db->options.features.work_height) {
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
    db->views->AddView(v.id, v.crossing_id, v.heading_deg, descriptors, std::move(points),
                       std::move(v.hue_hist), /*defer_indexing=*/true);
    db->views_per_crossing[v.crossing_id]++;
    db->keypoints += v.keypoint_count;
    return absl::OkStatus();
  });
  if (!loaded.ok()) return loaded;
  db->views->FinishLoading();
  absl::StatusOr<std::vector<storage::ClusterRecord>> clusters = store_->LoadClusters(record.id);
  if (!clusters.ok()) return clusters.status();
  Database::InstallClusters(*clusters, db->views.get());
  return db;
}

absl::StatusOr<std::shared_ptr<CrossingRegistry::Database>> CrossingRegistry::Find(
    const std::string& name) {
  absl::ReaderMutexLock lock(&mutex_);
  auto it = databases_.find(name);
  if (it == databases_.end()) {
    return absl::NotFoundError(absl::StrCat("database \"", name,
                                            "\" not found: create it with `waymark db create`"));
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
    return absl::AlreadyExistsError(absl::StrCat("database \"", request.name(), "\" already exists"));
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
    return absl::NotFoundError(absl::StrCat("database \"", name, "\" not found"));
  }
  absl::MutexLock db_lock(&it->second->mutex);
  if (absl::Status s = store_->DeleteDatabase(name); !s.ok()) return s;
  it->second->deleted = true;
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
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  if (db.crossing_ids.count(request.name())) {
    return absl::AlreadyExistsError(absl::StrCat("crossing \"", request.name(),
                                                 "\" already exists in database \"",
                                                 request.database(), "\""));
  }
  absl::StatusOr<storage::CrossingRecord> record =
      store_->AddCrossing(db.record.id, request.name(), request.label());
  if (!record.ok()) return record.status();
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
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  auto id_it = db.crossing_ids.find(request.name());
  if (id_it == db.crossing_ids.end()) {
    return absl::NotFoundError(absl::StrCat("crossing \"", request.name(),
                                            "\" not found in database \"", request.database(),
                                            "\""));
  }
  const int64_t crossing_id = id_it->second;
  // The remaining views, re-clustered in enrollment order, become the new memory and disk state
  // in one transaction.
  auto remaining = std::make_unique<ViewDatabase>(index_options_);
  int64_t keypoints = 0;
  for (uint32_t s = 0; s < db.views->views().size(); ++s) {
    const crossing::ViewEntry& v = db.views->views()[s];
    if (v.crossing_id == crossing_id) continue;
    remaining->AddView(v.view_id, v.crossing_id, v.heading_deg, db.views->Descriptors(s), v.points,
                       v.hue_hist, /*defer_indexing=*/true);
    keypoints += v.span.count;
  }
  remaining->FinishLoading();
  const auto clusters = remaining->ComputeClusters(db.options.clustering);
  absl::StatusOr<int> deleted = store_->DeleteCrossing(
      db.record.id, crossing_id, Database::ToRecords(*remaining, clusters));
  if (!deleted.ok()) return deleted.status();
  absl::StatusOr<std::vector<storage::ClusterRecord>> stored = store_->LoadClusters(db.record.id);
  if (!stored.ok()) return stored.status();
  Database::InstallClusters(*stored, remaining.get());
  db.views = std::move(remaining);
  db.keypoints = keypoints;
  db.crossings.erase(crossing_id);
  db.crossing_ids.erase(id_it);
  db.views_per_crossing.erase(crossing_id);
  v1::DeleteCrossingResponse response;
  response.set_views_deleted(*deleted);
  return response;
}

absl::StatusOr<v1::EnrollViewResponse> CrossingRegistry::EnrollView(
    const v1::EnrollViewRequest& request, bool* crossing_created) {
  const auto start = Clock::now();
  if (crossing_created != nullptr) *crossing_created = false;
  if (absl::Status s = ValidateCrossingName(request.crossing()); !s.ok()) return s;
  if (absl::Status s = ValidateHeading(request.heading_deg()); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;

  // Feature extraction is the slow part and needs no lock (options never change after creation).
  crossing::ExtractionTimings timings;
  absl::StatusOr<crossing::ImageFeatures> features =
      Extract(request.image().data(), db.options.features, &timings);
  if (!features.ok()) return features.status();
  if (features->descriptors.rows < kMinEnrollKeypoints) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the image has ", features->descriptors.rows, " SIFT keypoints at ",
        features->width, "x", features->height, "; a view needs at least ", kMinEnrollKeypoints,
        " to be recognizable (blank, blurred or textureless image?)"));
  }

  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  auto id_it = db.crossing_ids.find(request.crossing());
  const bool new_crossing = id_it == db.crossing_ids.end();
  if (new_crossing && !request.create_crossing()) {
    return absl::NotFoundError(absl::StrCat(
        "crossing \"", request.crossing(), "\" not found in database \"", request.database(),
        "\": add it first or set create_crossing"));
  }

  const auto match_start = Clock::now();
  const crossing::ClusterProposal proposal =
      db.views->ProposeCluster(features->descriptors, db.options.clustering);
  const double matching_ms = MsSince(match_start);
  storage::ViewRecord record =
      ToRecord(new_crossing ? 0 : id_it->second, request.heading_deg(), *features);
  if (request.store_image()) record.image = request.image().data();
  storage::ClusterAssignment assignment;
  if (proposal.cluster >= 0) {
    assignment.new_cluster = false;
    assignment.cluster_id = db.views->clusters()[proposal.cluster].cluster_id;
  }
  // A new crossing is created in the view's transaction: a failed or interrupted enrollment
  // leaves no empty crossing behind.
  absl::StatusOr<storage::AddViewResult> added =
      new_crossing ? store_->AddViewWithNewCrossing({db.record.id, request.crossing(), ""}, record,
                                                    assignment)
                   : store_->AddView(record, assignment);
  if (!added.ok()) return added.status();
  const int64_t crossing_id = added->crossing_id;
  if (new_crossing) {
    db.AddCrossingRecord({crossing_id, db.record.id, request.crossing(), ""});
    if (crossing_created != nullptr) *crossing_created = true;
  }

  const uint32_t slot = db.views->AddView(added->view_id, crossing_id, request.heading_deg(),
                                          features->descriptors, crossing::KeypointPositions(*features),
                                          features->hue_hist);
  if (proposal.cluster >= 0) {
    db.views->AddToCluster(proposal.cluster, slot);
  } else {
    db.views->NewCluster(added->cluster_id, slot);
  }
  db.views_per_crossing[crossing_id]++;
  db.keypoints += features->descriptors.rows;

  v1::EnrollViewResponse response;
  response.set_view_id(added->view_id);
  response.set_crossing_id(crossing_id);
  response.set_keypoints(features->descriptors.rows);
  response.set_cluster_id(added->cluster_id);
  response.set_new_cluster(proposal.cluster < 0);
  v1::StageTimings* t = response.mutable_timings();
  t->set_decode_ms(timings.decode_ms);
  t->set_extraction_ms(timings.extraction_ms);
  t->set_histogram_ms(timings.histogram_ms);
  t->set_matching_ms(matching_ms);
  t->set_total_ms(MsSince(start));
  return response;
}

absl::StatusOr<v1::RebuildClustersResponse> CrossingRegistry::RebuildClusters(
    const v1::RebuildClustersRequest& request) {
  const auto start = Clock::now();
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;
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
  Database::InstallClusters(*stored, db.views.get());
  if (request.has_cluster_threshold()) {
    if (absl::Status s = store_->UpdateDatabaseParams(db.record.id, ParamsToJson(params));
        !s.ok()) {
      return s;
    }
    db.params = params;
    db.options.clustering = options;
  }
  v1::RebuildClustersResponse response;
  response.set_clusters(static_cast<int32_t>(clusters.size()));
  response.set_views(static_cast<int32_t>(db.views->views().size()));
  response.set_elapsed_ms(MsSince(start));
  return response;
}

absl::StatusOr<v1::RecognizeResponse> CrossingRegistry::Recognize(
    const v1::RecognizeRequest& request) {
  const auto start = Clock::now();
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  const Database& db = **found;
  absl::StatusOr<crossing::RecognitionOptions> options =
      ResolveRecognitionOptions(db.options.recognition, request.params());
  if (!options.ok()) return options.status();

  crossing::ExtractionTimings timings;
  absl::StatusOr<crossing::ImageFeatures> features =
      Extract(request.image().data(), db.options.features, &timings);
  if (!features.ok()) return features.status();

  absl::ReaderMutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  absl::StatusOr<crossing::Recognition> result =
      crossing::Recognize(*db.views, *features, *options);
  if (!result.ok()) return result.status();

  v1::RecognizeResponse response;
  const auto& views = db.views->views();
  auto crossing_name = [&](int64_t id) {
    auto it = db.crossings.find(id);
    return it == db.crossings.end() ? std::string() : it->second.name;
  };
  response.set_recognized(result->recognized);
  if (result->recognized) {
    const crossing::ViewEntry& best = views[result->best_slot];
    response.set_crossing_id(best.crossing_id);
    response.set_crossing(crossing_name(best.crossing_id));
    response.set_view_id(best.view_id);
    response.set_heading_deg(best.heading_deg);
  }
  response.set_decision(result->decision);
  for (const crossing::Candidate& c : result->candidates) {
    const crossing::ViewEntry& v = views[c.slot];
    v1::Candidate* out = response.add_candidates();
    out->set_view_id(v.view_id);
    out->set_crossing_id(v.crossing_id);
    out->set_crossing(crossing_name(v.crossing_id));
    out->set_heading_deg(v.heading_deg);
    if (v.cluster >= 0) out->set_cluster_id(db.views->clusters()[v.cluster].cluster_id);
    out->set_is_center(c.is_center);
    out->set_matches(c.matches);
    out->set_tentative(c.tentative);
    out->set_similarity(c.similarity);
    out->set_decision(c.decision);
    out->set_kept(c.kept);
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
  t->set_total_ms(MsSince(start));
  return response;
}

}  // namespace waymark::service
