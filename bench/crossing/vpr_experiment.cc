#include "bench/crossing/vpr_experiment.h"

#include "server/crossing/place_evidence.h"

#include <algorithm>
#include <functional>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "server/crossing/enrollment.h"

namespace waymark::vpr {
namespace {

using Clock = std::chrono::steady_clock;
using crossing::ImageFeatures;
using crossing::RecognitionMode;
using crossing::RecognitionOptions;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double Ratio(int num, int den) {
  return den > 0 ? static_cast<double>(num) / den : std::numeric_limits<double>::quiet_NaN();
}

bool Contains(const std::vector<int64_t>& list, int64_t v) {
  return std::find(list.begin(), list.end(), v) != list.end();
}

std::vector<int64_t> ToPlaces(const std::vector<int>& refs) {
  return std::vector<int64_t>(refs.begin(), refs.end());
}

// The verified mode's winner for a query it rejected: the engine's decision step picks, among the
// kept candidates in list order, the first with the largest decision value (recognizer.cc
// Decide + ArgMax). Returns an index into `candidates`, or -1.
int DecisionWinner(const std::vector<crossing::Candidate>& candidates) {
  int best = -1;
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (!candidates[i].kept) continue;
    if (best < 0 || candidates[i].decision > candidates[best].decision) best = static_cast<int>(i);
  }
  return best;
}

}  // namespace

absl::StatusOr<const ImageFeatures*> FeatureCache::Get(const std::string& path) {
  auto it = cache_.find(path);
  if (it != cache_.end()) return it->second.get();
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read image ", path));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto start = Clock::now();
  absl::StatusOr<ImageFeatures> features = crossing::ExtractFeatures(bytes, options_);
  extraction_seconds_ += SecondsSince(start);
  if (!features.ok()) {
    return absl::Status(features.status().code(),
                        absl::StrCat(path, ": ", features.status().message()));
  }
  auto owned = std::make_unique<ImageFeatures>(*std::move(features));
  const ImageFeatures* out = owned.get();
  cache_.emplace(path, std::move(owned));
  return out;
}

absl::Status FeatureCache::Prefetch(const std::vector<std::string>& paths, int threads) {
  std::vector<std::string> todo;
  std::set<std::string> seen;
  for (const std::string& p : paths) {
    if (cache_.count(p) == 0 && seen.insert(p).second) todo.push_back(p);
  }
  std::mutex mu;
  size_t next = 0;
  absl::Status first_error;
  auto worker = [&] {
    while (true) {
      std::string path;
      {
        std::lock_guard<std::mutex> lock(mu);
        if (next >= todo.size() || !first_error.ok()) return;
        path = todo[next++];
      }
      std::ifstream in(path, std::ios::binary);
      absl::StatusOr<ImageFeatures> features =
          absl::NotFoundError(absl::StrCat("cannot read image ", path));
      const auto start = Clock::now();
      if (in) {
        const std::string bytes((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
        features = crossing::ExtractFeatures(bytes, options_);
      }
      const double seconds = SecondsSince(start);
      std::lock_guard<std::mutex> lock(mu);
      extraction_seconds_ += seconds;
      if (!features.ok()) {
        if (first_error.ok()) {
          first_error = absl::Status(features.status().code(),
                                     absl::StrCat(path, ": ", features.status().message()));
        }
        return;
      }
      cache_.emplace(path, std::make_unique<ImageFeatures>(*std::move(features)));
    }
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < std::max(1, threads); ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  return first_error;
}

absl::Status FeatureCache::Put(const std::string& key, const cv::Mat& image) {
  if (cache_.count(key)) return absl::OkStatus();
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) {
    return absl::InvalidArgumentError(absl::StrCat(key, ": cannot encode the image"));
  }
  const auto start = Clock::now();
  absl::StatusOr<ImageFeatures> features =
      crossing::ExtractFeatures(std::string(png.begin(), png.end()), options_);
  extraction_seconds_ += SecondsSince(start);
  if (!features.ok()) {
    return absl::Status(features.status().code(),
                        absl::StrCat(key, ": ", features.status().message()));
  }
  cache_.emplace(key, std::make_unique<ImageFeatures>(*std::move(features)));
  return absl::OkStatus();
}

std::vector<std::string> ImagePaths(const Protocol& protocol) {
  std::vector<std::string> paths;
  for (const Enrollment& e : protocol.enroll) paths.push_back(e.path);
  for (const Query& q : protocol.queries) paths.push_back(q.path);
  return paths;
}

double FeatureCache::mean_keypoints() const {
  if (cache_.empty()) return 0;
  double sum = 0;
  for (const auto& [path, f] : cache_) sum += f->descriptors.rows;
  return sum / cache_.size();
}

double Tally::accuracy() const { return Ratio(correct, known); }
double Tally::precision() const { return Ratio(correct, recognized); }
double Tally::false_accept_rate() const { return Ratio(false_accepts, unknown); }
double Tally::wrong_rate() const { return Ratio(wrong, known); }

Tally Summarize(const std::vector<QueryOutcome>& outcomes) {
  Tally t;
  for (const QueryOutcome& o : outcomes) {
    ++t.queries;
    t.total_ms += o.ms;
    if (o.recognized) ++t.recognized;
    if (o.known) {
      ++t.known;
      if (o.correct()) ++t.correct;
      if (o.recognized && o.winner_nearest) ++t.correct_nearest;
      if (o.recognized && o.winner_bracket) ++t.correct_bracket;
      if (o.recognized && !o.winner_correct) ++t.wrong;
    } else {
      ++t.unknown;
      if (o.recognized) ++t.false_accepts;
    }
  }
  return t;
}

absl::StatusOr<PreparedProtocol> Prepare(const Protocol& protocol, FeatureCache* cache,
                                         const crossing::ClusterOptions& clustering) {
  PreparedProtocol out;
  out.protocol = protocol;
  out.db = std::make_unique<crossing::ViewDatabase>();
  std::vector<const ImageFeatures*> enrolled;
  for (const Enrollment& e : protocol.enroll) {
    absl::StatusOr<const ImageFeatures*> f = cache->Get(e.path);
    if (!f.ok()) return f.status();
    enrolled.push_back(*f);
  }
  const auto start = Clock::now();
  for (size_t i = 0; i < protocol.enroll.size(); ++i) {
    const Enrollment& e = protocol.enroll[i];
    crossing::EnrollView(out.db.get(), static_cast<int64_t>(i) + 1, e.place, e.heading_deg,
                         *enrolled[i], clustering);
  }
  out.enroll_seconds = SecondsSince(start);
  // The retrieval mode's global descriptor, as the service trains it over a database's views.
  const auto train_start = Clock::now();
  std::vector<cv::Mat> dense;
  for (const ImageFeatures* f : enrolled) dense.push_back(f->dense);
  if (!dense.empty() && !dense.front().empty()) out.db->TrainGlobal(dense);
  out.vocabulary_seconds = SecondsSince(train_start);
  for (const Query& q : protocol.queries) {
    absl::StatusOr<const ImageFeatures*> f = cache->Get(q.path);
    if (!f.ok()) return f.status();
    out.query_features.push_back(*f);
  }
  return out;
}

absl::StatusOr<std::vector<QueryOutcome>> RunQueries(const PreparedProtocol& prepared,
                                                     const RecognitionOptions& options) {
  std::vector<QueryOutcome> outcomes;
  const crossing::ViewDatabase& db = *prepared.db;
  for (size_t i = 0; i < prepared.protocol.queries.size(); ++i) {
    const Query& q = prepared.protocol.queries[i];
    const auto start = Clock::now();
    absl::StatusOr<crossing::Recognition> r =
        crossing::Recognize(db, *prepared.query_features[i], options);
    const double ms = SecondsSince(start) * 1e3;
    if (!r.ok()) {
      return absl::Status(r.status().code(), absl::StrCat(prepared.protocol.name, " query ", q.path,
                                                          ": ", r.status().message()));
    }
    QueryOutcome o;
    o.known = !q.accepted.empty();
    o.recognized = r->recognized;
    o.distance_m = q.distance_m;
    o.angle_deg = q.angle_deg;
    o.ms = ms;
    int winner = -1;
    if (r->recognized) {
      for (size_t c = 0; c < r->candidates.size(); ++c) {
        if (r->candidates[c].slot == r->best_slot) winner = static_cast<int>(c);
      }
    } else if (options.mode != RecognitionMode::kPaper) {
      winner = DecisionWinner(r->candidates);
    }
    if (options.mode == RecognitionMode::kRetrieval) {
      for (const crossing::Candidate& c : r->candidates) {
        o.evidence.emplace_back(db.views()[c.slot].crossing_id, c.log10_nfa);
      }
      if (r->global.computed) {
        // The global path's chance model, weak frames included (place_evidence.h).
        const crossing::FrameEvidence e =
            crossing::GlobalFrameEvidence(r->global.best_place, r->global.log10_efa);
        o.evidence.emplace_back(e.crossing_id, e.log10_nfa);
      } else if (r->accepted_by_global) {
        const crossing::FrameEvidence e = crossing::GlobalAnswerEvidence(
            db.views()[r->best_slot].crossing_id, crossing::EvidenceOptions());
        o.evidence.emplace_back(e.crossing_id, e.log10_nfa);
      }
    }
    // The retrieval mode's global path may answer with a view that has no match set (so no
    // candidate): its place is the answer all the same.
    if (winner >= 0 || r->recognized) {
      o.has_winner = true;
      o.winner_place = db.views()[winner >= 0 ? r->candidates[winner].slot : r->best_slot]
                           .crossing_id;
      if (winner >= 0) {
        o.winner_matches = r->candidates[winner].matches;
        o.winner_tentative = r->candidates[winner].tentative;
      }
      o.winner_correct = Contains(q.accepted, o.winner_place);
      o.winner_nearest = o.winner_place == q.nearest;
      o.winner_bracket = Contains(q.bracket, o.winner_place);
    }
    outcomes.push_back(o);
  }
  return outcomes;
}

absl::StatusOr<std::vector<QueryOutcome>> RunQueries(const std::vector<PreparedProtocol>& parts,
                                                     const RecognitionOptions& options) {
  std::vector<QueryOutcome> all;
  for (const PreparedProtocol& part : parts) {
    absl::StatusOr<std::vector<QueryOutcome>> o = RunQueries(part, options);
    if (!o.ok()) return o.status();
    all.insert(all.end(), o->begin(), o->end());
  }
  return all;
}

std::vector<QueryOutcome> ReplayRejectionRule(const std::vector<QueryOutcome>& outcomes,
                                              int min_inliers, double min_share) {
  std::vector<QueryOutcome> out = outcomes;
  for (QueryOutcome& o : out) {
    const double share =
        o.winner_tentative > 0 ? o.winner_matches / static_cast<double>(o.winner_tentative) : 0;
    o.recognized = o.has_winner && o.winner_matches >= min_inliers && share >= min_share;
  }
  return out;
}

Protocol CorridorAll(const CorridorSet& set) {
  Protocol p;
  p.name = "corridor";
  for (size_t r = 0; r < set.refs.size(); ++r) {
    p.enroll.push_back({set.refs[r], static_cast<int64_t>(r), 0.0});
  }
  for (size_t q = 0; q < set.queries.size(); ++q) {
    Query query;
    query.path = set.queries[q];
    query.accepted = ToPlaces(set.ground_truth[q]);
    p.queries.push_back(query);
  }
  return p;
}

Protocol CorridorSegments(const CorridorSet& set, int segment) {
  Protocol p;
  p.name = absl::StrCat("corridor_segments_", segment);
  for (size_t r = 0; r < set.refs.size(); ++r) {
    p.enroll.push_back({set.refs[r], static_cast<int64_t>(r) / segment, 0.0});
  }
  for (size_t q = 0; q < set.queries.size(); ++q) {
    Query query;
    query.path = set.queries[q];
    for (int r : set.ground_truth[q]) {
      const int64_t place = r / segment;
      if (!Contains(query.accepted, place)) query.accepted.push_back(place);
    }
    p.queries.push_back(query);
  }
  return p;
}

Protocol CorridorPartial(const CorridorSet& set, int enrolled_last, int known_last,
                         int unknown_first) {
  Protocol p;
  p.name = "corridor_unknown";
  for (int r = 0; r <= enrolled_last && r < static_cast<int>(set.refs.size()); ++r) {
    p.enroll.push_back({set.refs[r], r, 0.0});
  }
  for (size_t q = 0; q < set.queries.size(); ++q) {
    const std::vector<int>& gt = set.ground_truth[q];
    if (gt.empty()) continue;
    const int lo = *std::min_element(gt.begin(), gt.end());
    const int hi = *std::max_element(gt.begin(), gt.end());
    Query query;
    query.path = set.queries[q];
    if (hi <= known_last) {
      query.accepted = ToPlaces(gt);
    } else if (lo < unknown_first) {
      continue;  // straddles the database's edge: neither clearly known nor clearly unknown
    }
    p.queries.push_back(query);
  }
  return p;
}

std::vector<Protocol> TripletFolds(const TripletSet& set) {
  std::vector<Protocol> folds;
  const size_t slots = set.images.empty() ? 0 : set.images[0].size();
  for (size_t k = 0; k < slots; ++k) {
    Protocol p;
    p.name = absl::StrCat("triplets_fold", k);
    for (int place = 0; place < set.places(); ++place) {
      const auto& images = set.images[place];
      if (k >= images.size()) continue;
      p.enroll.push_back({images[k], kTripletPlaceBase + place, 0.0});
      for (size_t j = 0; j < images.size(); ++j) {
        if (j == k) continue;
        Query q;
        q.path = images[j];
        q.accepted = {kTripletPlaceBase + place};
        p.queries.push_back(q);
      }
    }
    folds.push_back(std::move(p));
  }
  return folds;
}

Protocol TripletFoldWithUnknowns(const TripletSet& set, size_t k,
                                 const std::function<bool(int)>& known, std::string name) {
  Protocol p;
  p.name = std::move(name);
  for (int place = 0; place < set.places(); ++place) {
    const auto& images = set.images[place];
    const bool enrolled = known(place);
    if (enrolled && k < images.size()) {
      p.enroll.push_back({images[k], kTripletPlaceBase + place, 0.0});
    }
    for (size_t j = 0; j < images.size(); ++j) {
      if (enrolled && j == k) continue;
      Query q;
      q.path = images[j];
      if (enrolled) q.accepted = {kTripletPlaceBase + place};
      p.queries.push_back(q);
    }
  }
  return p;
}

std::vector<Protocol> TripletUnknownFolds(const TripletSet& set, int known_places) {
  std::vector<Protocol> folds;
  const size_t slots = set.images.empty() ? 0 : set.images[0].size();
  for (size_t k = 0; k < slots; ++k) {
    folds.push_back(TripletFoldWithUnknowns(
        set, k, [&](int place) { return place < known_places; },
        absl::StrCat("triplets_unknown_fold", k)));
  }
  return folds;
}

Protocol CorridorQueriesVsTripletDb(const CorridorSet& corridor, const TripletSet& triplets) {
  Protocol p;
  p.name = "corridor_vs_triplet_db";
  for (int place = 0; place < triplets.places(); ++place) {
    for (const std::string& image : triplets.images[place]) {
      p.enroll.push_back({image, kTripletPlaceBase + place, 0.0});
    }
  }
  for (const std::string& path : corridor.queries) {
    Query q;
    q.path = path;
    p.queries.push_back(q);
  }
  return p;
}

Protocol TripletQueriesVsCorridorDb(const CorridorSet& corridor, const TripletSet& triplets) {
  Protocol p;
  p.name = "triplets_vs_corridor_db";
  for (size_t r = 0; r < corridor.refs.size(); ++r) {
    p.enroll.push_back({corridor.refs[r], static_cast<int64_t>(r), 0.0});
  }
  for (const auto& images : triplets.images) {
    for (const std::string& image : images) {
      Query q;
      q.path = image;
      p.queries.push_back(q);
    }
  }
  return p;
}

double EnrolledSpacing(const FrameSequence& seq, int stride) {
  std::vector<double> gaps;
  for (size_t i = stride; i < seq.frames.size(); i += stride) {
    gaps.push_back(cv::norm(seq.frames[i].position - seq.frames[i - stride].position));
  }
  if (gaps.empty()) return 0;
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

Protocol OffPosition(const FrameSequence& seq, int stride, double tolerance_fraction) {
  Protocol p;
  p.name = absl::StrCat(seq.name, "_every", stride);
  std::vector<const PosedFrame*> enrolled;
  for (size_t i = 0; i < seq.frames.size(); i += stride) enrolled.push_back(&seq.frames[i]);
  if (enrolled.size() < 2) return p;
  for (const PosedFrame* f : enrolled) p.enroll.push_back({f->path, f->index, 0.0});
  const double tolerance = tolerance_fraction * EnrolledSpacing(seq, stride);
  const int last = enrolled.back()->index;
  for (const PosedFrame& f : seq.frames) {
    if (f.index % stride == 0 || f.index > last) continue;
    Query q;
    q.path = f.path;
    double best = std::numeric_limits<double>::infinity();
    const PosedFrame* nearest = nullptr;
    for (const PosedFrame* e : enrolled) {
      const double d = cv::norm(e->position - f.position);
      if (d < best) {
        best = d;
        nearest = e;
      }
    }
    for (const PosedFrame* e : enrolled) {
      if (cv::norm(e->position - f.position) <= best + tolerance) q.accepted.push_back(e->index);
    }
    q.nearest = nearest->index;
    q.bracket = {f.index / stride * stride, (f.index / stride + 1) * stride};
    q.distance_m = best;
    q.angle_deg = RotationAngleDeg(nearest->rotation, f.rotation);
    p.queries.push_back(q);
  }
  return p;
}

}  // namespace waymark::vpr
