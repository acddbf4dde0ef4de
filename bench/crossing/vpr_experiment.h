#ifndef WAYMARK_BENCH_CROSSING_VPR_EXPERIMENT_H_
#define WAYMARK_BENCH_CROSSING_VPR_EXPERIMENT_H_

// A small place-recognition experiment runner over the crossing engine: enroll a list of images
// (each with a place id) into a ViewDatabase with the paper's clustering, recognize a list of
// queries, and count accuracy, precision and false accepts. Features are extracted once per image
// and cached, so many experiments and parameter sweeps over the same images cost little.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "bench/crossing/vpr_datasets.h"
#include "server/crossing/features.h"
#include "server/crossing/options.h"
#include "server/crossing/recognizer.h"
#include "server/crossing/view_database.h"

namespace waymark::vpr {

// Decodes and extracts each image file once (decode, resize to the working resolution, SIFT, hue
// histogram: crossing::ExtractFeatures).
class FeatureCache {
 public:
  explicit FeatureCache(const crossing::FeatureOptions& options = {}) : options_(options) {}

  // NOT_FOUND for an unreadable file, the extraction's error for an undecodable one.
  absl::StatusOr<const crossing::ImageFeatures*> Get(const std::string& path);
  // Extracts an image already in memory (e.g. a view rendered from a panorama) under `key`, the
  // name protocols then use as its path; a key already cached is kept.
  absl::Status Put(const std::string& key, const cv::Mat& image);
  // Extracts the images of `paths` not cached yet on `threads` threads (the first error wins).
  absl::Status Prefetch(const std::vector<std::string>& paths, int threads);
  size_t size() const { return cache_.size(); }
  double extraction_seconds() const { return extraction_seconds_; }
  double mean_keypoints() const;

 private:
  crossing::FeatureOptions options_;
  std::map<std::string, std::unique_ptr<crossing::ImageFeatures>> cache_;
  double extraction_seconds_ = 0;  // summed over threads
};

// Place ids of the triplets (p0..p9 -> 1000..1009), apart from corridor refs (0..110) so that
// mixed databases never confuse the two.
inline constexpr int64_t kTripletPlaceBase = 1000;

struct Enrollment {
  std::string path;
  int64_t place = 0;  // enrolled as the view's crossing id
  double heading_deg = 0;
};

struct Query {
  std::string path;
  // Places whose recognition counts as correct. Empty: the place is not in the database and the
  // query must be rejected.
  std::vector<int64_t> accepted;
  // Off-position experiments only: the enrolled frame nearest in position (the strict answer),
  // the two enrolled frames around the query in time, and the distance / rotation to the nearest.
  int64_t nearest = -1;
  std::vector<int64_t> bracket;
  double distance_m = -1;
  double angle_deg = -1;
};

struct Protocol {
  std::string name;
  std::vector<Enrollment> enroll;
  std::vector<Query> queries;
};

// Every image a protocol reads (enrolled and queried), for FeatureCache::Prefetch.
std::vector<std::string> ImagePaths(const Protocol& protocol);

// The outcome of one query. The "winner" is the view the decision step picked (paper: the
// recognized view; verified: the decision's winner before the rejection rule), so the verified
// mode's rejection rule can be replayed for other thresholds (ReplayRejectionRule).
struct QueryOutcome {
  bool known = true;  // the query's place is in the database
  bool recognized = false;
  bool has_winner = false;
  int64_t winner_place = -1;
  int winner_matches = 0;       // M of the winner (verified: epipolar inliers)
  int winner_tentative = 0;     // verified: ratio-test matches before verification
  bool winner_correct = false;  // winner_place is in Query::accepted
  bool winner_nearest = false;  // winner_place == Query::nearest
  bool winner_bracket = false;  // winner_place is in Query::bracket
  double distance_m = -1;
  double angle_deg = -1;
  double ms = 0;  // Recognize() wall time
  // Retrieval mode: every candidate's place and log10 NFA (what a stream's evidence filter gets).
  std::vector<std::pair<int64_t, double>> evidence;

  bool correct() const { return recognized && winner_correct; }
  bool false_accept() const { return recognized && !known; }
};

struct Tally {
  int queries = 0;
  int known = 0;            // queries whose place is in the database
  int correct = 0;          // known, recognized, right place
  int correct_nearest = 0;  // off-position: recognized as the nearest enrolled frame
  int correct_bracket = 0;  // off-position: recognized as one of the two frames around it in time
  int recognized = 0;       // accepted answers (known or not)
  int wrong = 0;            // known, recognized as a wrong place
  int unknown = 0;          // queries whose place is not in the database
  int false_accepts = 0;    // unknown, recognized anyway
  double total_ms = 0;

  // Correct / known queries (non-recognized counts as wrong): recall@1 on the corridor.
  double accuracy() const;
  double precision() const;          // correct / recognized
  double false_accept_rate() const;  // false accepts / unknown queries
  double wrong_rate() const;         // wrong answers / known queries
  double mean_ms() const { return queries ? total_ms / queries : 0; }
};
Tally Summarize(const std::vector<QueryOutcome>& outcomes);

// A protocol with its database built and its query features at hand.
struct PreparedProtocol {
  Protocol protocol;
  std::unique_ptr<crossing::ViewDatabase> db;
  std::vector<const crossing::ImageFeatures*> query_features;
  double enroll_seconds = 0;
  double vocabulary_seconds = 0;  // training the global vocabulary and encoding the views
};

// Enrolls every image of the protocol (views in list order, the paper's incremental clustering)
// and extracts the queries' features (through the cache).
absl::StatusOr<PreparedProtocol> Prepare(const Protocol& protocol, FeatureCache* cache,
                                         const crossing::ClusterOptions& clustering = {});

// Recognizes every query of every part with `options`; outcomes concatenated in order.
absl::StatusOr<std::vector<QueryOutcome>> RunQueries(const PreparedProtocol& prepared,
                                                     const crossing::RecognitionOptions& options);
absl::StatusOr<std::vector<QueryOutcome>> RunQueries(const std::vector<PreparedProtocol>& parts,
                                                     const crossing::RecognitionOptions& options);

// The verified mode's rejection rule (recognizer.cc: the decision's winner needs `min_inliers`
// inliers and `min_share` of its tentative matches) applied again to the outcomes of a verified
// run. Exact for a stricter share at the run's own min_inliers (the share only filters the
// winner); not for another min_inliers, which also decides which views the engine verifies at
// all. vpr_eval checks the replay against the engine.
std::vector<QueryOutcome> ReplayRejectionRule(const std::vector<QueryOutcome>& outcomes,
                                              int min_inliers, double min_share);

// --- The experiments ---------------------------------------------------------------------------

// Every ref its own place (place = ref index, heading 0), every query; accepted = ground truth.
Protocol CorridorAll(const CorridorSet& set);
// Every ref enrolled with place = its index / `segment`: the corridor cut into stretches of
// `segment` frames, each a "crossing" a robot passes through; queries in traversal order,
// accepted = the stretches of their ground-truth refs. For evidence over a stream.
Protocol CorridorSegments(const CorridorSet& set, int segment);
// Refs 0..enrolled_last enrolled. Queries whose ground truth lies entirely in 0..known_last are
// known (accepted = ground truth), those whose ground truth lies entirely in
// unknown_first..end are unknown; the rest (straddling the boundary) are left out.
Protocol CorridorPartial(const CorridorSet& set, int enrolled_last = 54, int known_last = 52,
                         int unknown_first = 60);
// Fold k: image k of every place enrolled, the other images of each place queried.
std::vector<Protocol> TripletFolds(const TripletSet& set);
// Fold k: image k of places 0..known_places-1 enrolled; their other images are known queries,
// every image of the remaining places an unknown query.
std::vector<Protocol> TripletUnknownFolds(const TripletSet& set, int known_places = 5);
// One triplet fold: of the places `known` says yes to, image k is enrolled and the others query
// it; every image of the other places is an unknown query.
Protocol TripletFoldWithUnknowns(const TripletSet& set, size_t k,
                                 const std::function<bool(int)>& known, std::string name);
// All triplet images enrolled (place = kTripletPlaceBase + p); every corridor query is unknown.
Protocol CorridorQueriesVsTripletDb(const CorridorSet& corridor, const TripletSet& triplets);
// All corridor refs enrolled; every triplet image is unknown.
Protocol TripletQueriesVsCorridorDb(const CorridorSet& corridor, const TripletSet& triplets);

// Every `stride`-th frame enrolled as a place (place = frame index); the frames between the first
// and the last enrolled frame are queries. A query is correct when the recognized frame is at most
// `tolerance_fraction` x the enrolled spacing (median distance between consecutive enrolled
// frames) farther from the query than the nearest enrolled frame (by ground-truth position): the
// nearest frame always counts, its neighbour counts when the query lies near the middle.
Protocol OffPosition(const FrameSequence& seq, int stride, double tolerance_fraction = 0.5);
// The enrolled spacing OffPosition uses (metres).
double EnrolledSpacing(const FrameSequence& seq, int stride);

}  // namespace waymark::vpr

#endif  // WAYMARK_BENCH_CROSSING_VPR_EXPERIMENT_H_
