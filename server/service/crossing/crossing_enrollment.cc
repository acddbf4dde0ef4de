// CrossingRegistry::EnrollView: duplicate detection by image hash, feature extraction, the
// cluster proposal and the commit, plain or replacing views (crossing_registry.h, crossing.proto).

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"
#include "server/common/stopwatch.h"
#include "server/service/crossing/crossing_registry.h"

#include "server/service/crossing/crossing_loading.h"
#include "storage/sha256.h"

namespace waymark::service {

struct CrossingRegistry::CommittedView {
  storage::AddViewResult added;
  bool new_cluster = false;
  double matching_ms = 0;
  std::vector<int64_t> replaced_view_ids;
};

namespace {

// A view with fewer keypoints could never reach N1 = 10 matches: refuse it at enrollment.
constexpr int kMinEnrollKeypoints = 10;

// Whether `view` sits at the request's crossing (`crossing_id`, the id of its name), heading and
// position: the place a `replace` request takes.
bool AtRequestedPlace(const crossing::ViewEntry& view, int64_t crossing_id,
                      const v1::EnrollViewRequest& request) {
  return view.crossing_id == crossing_id &&
         SameHeading(view.heading_deg, RequestedHeading(request)) &&
         view.position == request.position();
}

// The stored view that makes `request` a duplicate: the one holding the same image. With
// `replace`, only when it sits at the requested crossing, heading and position already; elsewhere
// it is one of the views the request replaces (the image moves here).
const crossing::ViewEntry* DuplicateOf(const ResidentDatabase& db,
                                       const v1::EnrollViewRequest& request,
                                       const std::string& content) {
  const std::optional<int64_t> holder = db.contents.Find(content);
  if (!holder.has_value()) return nullptr;
  // Never null while the contents and the views change together (under the exclusive lock).
  const crossing::ViewEntry* view = db.FindView(*holder);
  if (view == nullptr || !request.replace()) return view;
  auto id_it = db.crossing_ids.find(request.crossing());
  const bool same_place =
      id_it != db.crossing_ids.end() && AtRequestedPlace(*view, id_it->second, request);
  return same_place ? view : nullptr;
}

// NOT_FOUND for a crossing that does not exist and may not be created: a bad request, whatever
// its image.
absl::Status CheckCrossing(const ResidentDatabase& db, const v1::EnrollViewRequest& request) {
  if (request.create_crossing() || db.crossing_ids.count(request.crossing()) > 0) {
    return absl::OkStatus();
  }
  return absl::NotFoundError(absl::StrCat("crossing ", QuoteClientText(request.crossing()),
                                          " not found in database ",
                                          QuoteClientText(request.database()),
                                          ": add it first or set create_crossing"));
}

// A view's heading in an answer: heading_unknown (and heading_deg 0) for a view with none.
void SetResponseHeading(double heading_deg, v1::EnrollViewResponse* response) {
  response->set_heading_unknown(std::isnan(heading_deg));
  response->set_heading_deg(response->heading_unknown() ? 0 : heading_deg);
}

v1::EnrollViewResponse DuplicateAnswer(const ResidentDatabase& db, const crossing::ViewEntry& view,
                                       Clock::time_point start) {
  v1::EnrollViewResponse response;
  response.set_outcome(v1::ENROLL_OUTCOME_DUPLICATE);
  response.set_view_id(view.view_id);
  response.set_crossing_id(view.crossing_id);
  response.set_crossing(db.CrossingName(view.crossing_id));
  SetResponseHeading(view.heading_deg, &response);
  response.set_position(view.position);
  response.mutable_timings()->set_total_ms(MsSince(start));
  return response;
}

// Puts a committed view into memory: its crossing if new, its slot, cluster, global descriptor
// and counters.
void InstallView(ResidentDatabase& db, const storage::AddViewResult& added, int join_cluster,
                 const v1::EnrollViewRequest& request,
                 const CrossingRegistry::PreparedEnrollment& prepared, bool new_crossing) {
  const crossing::ImageFeatures& features = prepared.features;
  if (new_crossing) db.AddCrossingRecord({added.crossing_id, db.record.id, request.crossing(), ""});
  const uint32_t slot = db.views->AddView(added.view_id, added.crossing_id, RequestedHeading(request),
                                          features.descriptors,
                                          crossing::KeypointPositions(features), features.hue_hist);
  db.views->SetPosition(slot, request.position());
  if (prepared.global.has_value()) InstallGlobal(db, slot, added.view_id, *prepared.global);
  if (join_cluster >= 0) {
    db.views->AddToCluster(join_cluster, slot);
  } else {
    db.views->NewCluster(added.cluster_id, slot);
  }
  db.views_per_crossing[added.crossing_id]++;
  db.keypoints += features.descriptors.rows;
  db.contents.Add(added.view_id, prepared.content);
}

}  // namespace

absl::StatusOr<v1::EnrollViewResponse> CrossingRegistry::EnrollView(
    const v1::EnrollViewRequest& request, bool* crossing_created) {
  absl::StatusOr<PreparedEnrollment> prepared = PrepareEnrollment(request);
  if (crossing_created != nullptr) *crossing_created = false;
  if (!prepared.ok()) return prepared.status();
  return CommitEnrollment(request, std::move(*prepared), crossing_created);
}

absl::StatusOr<CrossingRegistry::PreparedEnrollment> CrossingRegistry::PrepareEnrollment(
    const v1::EnrollViewRequest& request) {
  PreparedEnrollment prepared;
  prepared.start = Clock::now();
  if (absl::Status s = ValidateCrossingName(request.crossing()); !s.ok()) return s;
  if (request.heading_unknown()) {
    if (request.heading_deg() != 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "heading_deg = ", request.heading_deg(), " with heading_unknown: a view has a heading or "
          "none (send heading_deg 0 with heading_unknown)"));
    }
  } else if (absl::Status s = ValidateHeading(request.heading_deg()); !s.ok()) {
    return s;
  }
  if (absl::Status s = ValidatePosition(request.position()); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;
  absl::StatusOr<std::string> content = storage::Sha256(request.image().data());
  if (!content.ok()) return content.status();
  prepared.content = std::move(*content);

  // A duplicate needs no features: answer it before the slow part.
  {
    absl::ReaderMutexLock lock(&db.mutex);
    if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
    if (absl::Status s = CheckCrossing(db, request); !s.ok()) return s;
    if (const crossing::ViewEntry* held = DuplicateOf(db, request, prepared.content)) {
      prepared.answer = DuplicateAnswer(db, *held, prepared.start);
      return prepared;
    }
  }

  // Feature extraction is the slow part and needs no lock (options never change after creation).
  absl::StatusOr<crossing::ImageFeatures> features =
      Extract(request.image().data(), db.options.features, &prepared.timings);
  if (!features.ok()) return features.status();
  if (features->descriptors.rows < kMinEnrollKeypoints) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the image has ", features->descriptors.rows, " SIFT keypoints at ", features->width, "x",
        features->height, "; a view needs at least ", kMinEnrollKeypoints,
        " to be recognizable (blank, blurred or textureless image?)"));
  }
  prepared.features = std::move(*features);
  if (db.options.features.global_descriptor) {
    absl::StatusOr<PreparedGlobal> global = PrepareGlobal(db, prepared.features);
    if (!global.ok()) return global.status();
    prepared.global = *std::move(global);
  }
  return prepared;
}

absl::StatusOr<v1::EnrollViewResponse> CrossingRegistry::CommitEnrollment(
    const v1::EnrollViewRequest& request, PreparedEnrollment prepared, bool* crossing_created) {
  if (crossing_created != nullptr) *crossing_created = false;
  if (prepared.answer.has_value()) return *prepared.answer;
  const auto start = prepared.start;
  const crossing::ExtractionTimings& timings = prepared.timings;
  const crossing::ImageFeatures& features = prepared.features;
  const std::string& content = prepared.content;
  absl::StatusOr<std::shared_ptr<Database>> found = Find(request.database());
  if (!found.ok()) return found.status();
  Database& db = **found;

  // Servers sharing the database take turns, each first reading what the others enrolled.
  absl::StatusOr<WriteScope> writing = WriteScope::Begin(*store_, index_options_, db);
  if (!writing.ok()) return writing.status();
  absl::MutexLock lock(&db.mutex);
  if (absl::Status s = db.CheckAlive(); !s.ok()) return s;
  // Again, in the critical section of the commit: the crossing may have been deleted, and an
  // enrollment of the same image may have committed while this one was extracting.
  if (absl::Status s = CheckCrossing(db, request); !s.ok()) return s;
  if (const crossing::ViewEntry* held = DuplicateOf(db, request, content)) {
    return DuplicateAnswer(db, *held, start);
  }
  auto id_it = db.crossing_ids.find(request.crossing());
  const bool new_crossing = id_it == db.crossing_ids.end();
  const int64_t crossing_id = new_crossing ? 0 : id_it->second;
  storage::ViewRecord record = ToViewRecord(crossing_id, RequestedHeading(request), features);
  record.content_sha256 = content;
  record.position = request.position();
  if (request.store_image()) record.image = request.image().data();
  if (prepared.global.has_value()) FillGlobalRecord(db, *prepared.global, &record);

  // What `replace` deletes: the crossing's views at this heading and position and the view
  // holding this image elsewhere (DuplicateOf returned null for it).
  const std::optional<int64_t> holder = db.contents.Find(content);
  const auto replaced = [&](const crossing::ViewEntry& v) {
    return (!new_crossing && AtRequestedPlace(v, crossing_id, request)) ||
           (holder.has_value() && v.view_id == *holder);
  };
  const bool replaces = request.replace() &&
                        std::any_of(db.views->views().begin(), db.views->views().end(), replaced);
  absl::StatusOr<CommittedView> committed =
      replaces ? CommitReplacingViews(db, request, record, prepared, new_crossing, replaced)
               : CommitView(db, request, record, prepared, new_crossing);
  if (!committed.ok()) return committed.status();
  global_worker_->Schedule(*found);  // a vocabulary may be due
  if (new_crossing && crossing_created != nullptr) *crossing_created = true;

  v1::EnrollViewResponse response;
  response.set_outcome(v1::ENROLL_OUTCOME_STORED);
  response.set_view_id(committed->added.view_id);
  response.set_crossing_id(committed->added.crossing_id);
  response.set_crossing(request.crossing());
  SetResponseHeading(RequestedHeading(request), &response);
  response.set_position(request.position());
  response.set_crossing_created(new_crossing);
  response.set_keypoints(features.descriptors.rows);
  response.set_cluster_id(committed->added.cluster_id);
  response.set_new_cluster(committed->new_cluster);
  for (int64_t id : committed->replaced_view_ids) response.add_replaced_view_ids(id);
  v1::StageTimings* t = response.mutable_timings();
  t->set_decode_ms(timings.decode_ms);
  t->set_extraction_ms(timings.extraction_ms);
  t->set_histogram_ms(timings.histogram_ms);
  t->set_matching_ms(committed->matching_ms);
  t->set_total_ms(MsSince(start));
  return response;
}

absl::StatusOr<CrossingRegistry::CommittedView> CrossingRegistry::CommitView(
    Database& db, const v1::EnrollViewRequest& request, const storage::ViewRecord& record,
    const PreparedEnrollment& prepared, bool new_crossing) {
  const crossing::ImageFeatures& features = prepared.features;
  CommittedView committed;
  const auto match_start = Clock::now();
  const crossing::ClusterProposal proposal =
      db.views->ProposeCluster(features.descriptors, db.options.clustering);
  committed.matching_ms = MsSince(match_start);
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
  db.NoteOwnWrite(/*reload=*/false);
  committed.added = *added;
  committed.new_cluster = proposal.cluster < 0;
  InstallView(db, *added, proposal.cluster, request, prepared, new_crossing);
  return committed;
}

absl::StatusOr<CrossingRegistry::CommittedView> CrossingRegistry::CommitReplacingViews(
    Database& db, const v1::EnrollViewRequest& request, const storage::ViewRecord& record,
    const PreparedEnrollment& prepared, bool new_crossing,
    const std::function<bool(const crossing::ViewEntry&)>& replaced) {
  const crossing::ImageFeatures& features = prepared.features;
  CommittedView committed;
  // The rest re-clustered in enrollment order, then the new view proposed against that: exactly
  // what RebuildClusters gives for the database after the commit.
  RemainingViews remaining = CopyViewsExcept(*db.views, replaced, index_options_);
  const auto match_start = Clock::now();
  const std::vector<crossing::ClusterEntry> clusters =
      remaining.views->ComputeClusters(db.options.clustering);
  remaining.views->SetClusters(clusters);
  const crossing::ClusterProposal proposal =
      remaining.views->ProposeCluster(features.descriptors, db.options.clustering);
  committed.matching_ms = MsSince(match_start);

  storage::ViewReplacement replacement;
  replacement.database_id = db.record.id;
  replacement.replaced_view_ids = remaining.dropped_view_ids;
  replacement.clusters = Database::ToRecords(*remaining.views, clusters);
  replacement.view = record;
  replacement.join_cluster = proposal.cluster;
  replacement.create_crossing = new_crossing;
  replacement.crossing_name = request.crossing();
  absl::StatusOr<storage::ViewReplacementResult> stored = store_->ReplaceViews(replacement);
  if (!stored.ok()) return stored.status();
  db.NoteOwnWrite(/*reload=*/true);

  // Memory follows the disk: the remaining views with the stored cluster ids, then the new view.
  Database::InstallClusters(stored->clusters, remaining.views.get());
  db.views = std::move(remaining.views);
  db.keypoints = remaining.keypoints;
  for (int64_t view_id : remaining.dropped_view_ids) db.contents.Remove(view_id);
  for (const auto& [crossing_id, count] : remaining.dropped_per_crossing) {
    db.views_per_crossing[crossing_id] -= count;
  }
  committed.added = stored->added;
  committed.new_cluster = proposal.cluster < 0;
  committed.replaced_view_ids = remaining.dropped_view_ids;
  InstallView(db, stored->added, proposal.cluster, request, prepared, new_crossing);
  return committed;
}

}  // namespace waymark::service
