// waymark-vpr-eval: crossing recognition on real place-recognition data (../shared/data, read in
// place), in the paper's mode and the verified mode, with the sweeps that justify the defaults.
//
//   waymark-vpr-eval --shared ../shared --out DIR [--json]
//
// Writes DIR/vpr_results.json and DIR/vpr_results.md; progress goes to stderr.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "bench/crossing/vpr_datasets.h"
#include "bench/crossing/vpr_experiment.h"
#include "server/crossing/place_evidence.h"
#include "server/crossing/vlad.h"

namespace waymark::vpr {
namespace {

using Clock = std::chrono::steady_clock;
using crossing::RecognitionMode;
using crossing::RecognitionOptions;
using json = nlohmann::json;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string Pct(double v) {
  if (std::isnan(v)) return "-";
  return absl::StrFormat("%.1f %%", 100.0 * v);
}

json Num(double v) { return std::isnan(v) ? json(nullptr) : json(v); }

std::string Frac(int num, int den) { return absl::StrCat(num, "/", den); }

// The sets the paper-vs-verified comparison and the sweeps are computed on.
constexpr const char* kCorridor = "corridor";
constexpr const char* kTriplets = "triplets";
constexpr const char* kCorridorUnknown = "corridor_unknown";
constexpr const char* kTripletsUnknown = "triplets_unknown";
constexpr const char* kCorridorVsTriplets = "corridor_vs_triplet_db";
constexpr const char* kTripletsVsCorridor = "triplets_vs_corridor_db";

constexpr const char* kCorridorSegments = "corridor_segments";
// Corridor stretches of this many frames are the "crossings" of the stream experiment.
constexpr int kSegment = 10;

constexpr int kKittiStrides[] = {2, 5, 10};
constexpr int kBonnStrides[] = {5, 10, 20, 40};
constexpr double kTolerance = 0.5;  // off-position: fraction of the enrolled spacing

// The false-accept ceiling of the operating point: on every unknown set.
constexpr double kMaxFalseAccept = 0.05;
constexpr int kThreads = 2;  // feature extraction

struct Group {
  std::string name;
  std::string description;
  std::vector<PreparedProtocol> parts;
  bool off_position = false;
  std::string dataset;  // off-position: "kitti" or "bonn"
  int stride = 0;
  double spacing_m = 0;
};

// One recognition configuration, its outcomes per group and the wall time per group.
struct Run {
  std::string label;
  RecognitionOptions options;
  std::map<std::string, std::vector<QueryOutcome>> outcomes;
  std::map<std::string, double> seconds;
  bool replayed = false;  // verified rule thresholds applied to another run's outcomes

  const std::vector<QueryOutcome>* Get(const std::string& group) const {
    auto it = outcomes.find(group);
    return it == outcomes.end() ? nullptr : &it->second;
  }
  // The outcomes of several groups concatenated (a dataset's strides pooled).
  std::vector<QueryOutcome> Pool(const std::vector<std::string>& groups) const {
    std::vector<QueryOutcome> all;
    for (const std::string& g : groups) {
      if (const auto* o = Get(g)) all.insert(all.end(), o->begin(), o->end());
    }
    return all;
  }
  std::optional<Tally> TallyOf(const std::vector<std::string>& groups) const {
    bool any = false;
    for (const auto& g : groups) any = any || Get(g) != nullptr;
    if (!any) return std::nullopt;
    return Summarize(Pool(groups));
  }
};

std::string ModeName(RecognitionMode mode) {
  switch (mode) {
    case RecognitionMode::kVerified: return "verified";
    case RecognitionMode::kRetrieval: return "retrieval";
    case RecognitionMode::kPaper: break;
  }
  return "paper";
}

json OptionsJson(const RecognitionOptions& o) {
  json j;
  j["mode"] = ModeName(o.mode);
  j["ratio"] = o.ratio;
  j["n0"] = o.n0;
  j["n1"] = o.n1;
  j["n2"] = o.n2;
  j["alpha"] = o.alpha;
  j["beta"] = o.beta;
  j["verified_ratio"] = o.verified_ratio;
  j["min_inliers"] = o.min_inliers;
  j["min_inlier_share"] = o.min_inlier_share;
  j["ransac_threshold_px"] = o.ransac_threshold_px;
  j["shortlist"] = o.shortlist;
  j["max_log10_nfa"] = o.max_log10_nfa;
  j["global_shortlist"] = o.global_shortlist;
  j["global_evidence"] = o.global_evidence;
  j["min_global_lift"] = o.min_global_lift;
  return j;
}

json TallyJson(const Tally& t) {
  json j;
  j["queries"] = t.queries;
  j["known"] = t.known;
  j["correct"] = t.correct;
  j["recognized"] = t.recognized;
  j["wrong"] = t.wrong;
  j["unknown"] = t.unknown;
  j["false_accepts"] = t.false_accepts;
  j["accuracy"] = Num(t.accuracy());
  j["precision"] = Num(t.precision());
  j["false_accept_rate"] = Num(t.false_accept_rate());
  j["wrong_rate"] = Num(t.wrong_rate());
  j["mean_ms_per_query"] = t.mean_ms();
  if (t.correct_nearest || t.correct_bracket) {
    j["correct_nearest"] = t.correct_nearest;
    j["correct_bracket"] = t.correct_bracket;
  }
  return j;
}

class Evaluation {
 public:
  Evaluation(std::string shared, const crossing::FeatureOptions& features, bool quick)
      : shared_(std::move(shared)), cache_(features), quick_(quick) {}

  bool Load();
  void RunAll();
  json ToJson() const;
  std::string ToMarkdown() const;

 private:
  absl::Status AddGroup(const std::string& name, const std::string& description,
                        const std::vector<Protocol>& protocols, Group extra = {});
  Run Execute(const std::string& label, const RecognitionOptions& options,
              const std::vector<std::string>& groups);
  std::string SequenceReport(const Run& run, double threshold) const;
  void VladReport(int words, int sample_rows);
 public:
  // Every retrieval-mode candidate of every query with what an acceptance rule could use (its
  // geometric NFA, global similarity and z, the query's similarities over all views), as CSV:
  // the data to design and calibrate the rule on. Empty path: nothing.
  // `vocabulary_rows` > 0: each database's vocabulary learnt again from that many dense
  // descriptors per view first.
  void AcceptanceDump(const std::string& path, int vocabulary_rows);

 private:
  std::vector<std::string> GroupsOf(const std::string& dataset) const;
  std::vector<std::string> AllGroups() const;
  std::vector<std::string> PaperSweepGroups() const;
  // Score of a run for the operating-point choice: the mean accuracy over the known-place sets
  // (corridor, triplets, KITTI pooled, Bonn pooled); and the worst false-accept rate over the
  // unknown sets.
  double MeanAccuracy(const Run& run) const;
  double WorstFalseAccept(const Run& run) const;
  std::vector<std::pair<std::string, std::vector<std::string>>> AccuracySets() const;
  std::vector<std::string> UnknownSets() const;

  std::string MainTable() const;
  std::string OffPositionTables() const;
  std::string SweepHeader(const std::string& leading, const std::string& trailing,
                          int extra_columns) const;
  std::string SweepCells(const Run& r) const;
  std::string PaperSweepTable() const;
  std::string VerifiedSweepTable() const;
  std::string DecisionWeightsTable() const;

  std::string shared_;
  DataPaths paths_;
  FeatureCache cache_;
  bool quick_ = false;  // the three modes at their defaults only (feature experiments)
  std::optional<CorridorSet> corridor_;
  std::optional<TripletSet> triplets_;
  std::optional<FrameSequence> kitti_, bonn_;
  std::vector<std::string> missing_;
  std::vector<Group> groups_;
  double load_seconds_ = 0;

  Run paper_, verified_;
  Run verified_inliers_only_;  // verified, alpha = 1, beta = 0: the hue term left out
  std::vector<Run> retrieval_;  // retrieval mode at several max_log10_nfa
  std::vector<std::string> sequence_;  // the evidence filter over the corridor traversal
  std::vector<Run> paper_sweep_;
  std::vector<Run> verified_sweep_;  // replayed from verified_ (and verified_none_)
  Run verified_chosen_;              // the chosen point run for real (when not the defaults)
  bool chosen_is_default_ = true;
  int chosen_index_ = -1;
  int replay_mismatches_ = 0;
  int replay_checked_ = 0;
  double total_seconds_ = 0;
};

absl::Status Evaluation::AddGroup(const std::string& name, const std::string& description,
                                  const std::vector<Protocol>& protocols, Group extra) {
  Group g = std::move(extra);
  g.name = name;
  g.description = description;
  for (const Protocol& p : protocols) {
    absl::StatusOr<PreparedProtocol> prepared = Prepare(p, &cache_);
    if (!prepared.ok()) return prepared.status();
    g.parts.push_back(*std::move(prepared));
  }
  groups_.push_back(std::move(g));
  return absl::OkStatus();
}

bool Evaluation::Load() {
  const auto start = Clock::now();
  paths_ = DefaultDataPaths(shared_);
  auto note_missing = [&](const std::string& what, const absl::Status& s) {
    std::cerr << "skipping " << what << ": " << s.message() << "\n";
    missing_.push_back(absl::StrCat(what, ": ", s.message()));
  };
  if (auto c = LoadCorridor(paths_.corridor); c.ok())
    corridor_ = *c;
  else
    note_missing("corridor", c.status());
  if (auto t = LoadTriplets(paths_.triplets); t.ok())
    triplets_ = *t;
  else
    note_missing("triplets", t.status());
  if (auto k = LoadKittiFrames(paths_.kitti); k.ok())
    kitti_ = *k;
  else
    note_missing("KITTI", k.status());
  if (auto b = LoadBonnFrames(paths_.bonn); b.ok())
    bonn_ = *b;
  else
    note_missing("Bonn", b.status());

  auto check = [&](absl::Status s) {
    if (!s.ok()) std::cerr << "error: " << s.message() << "\n";
    return s.ok();
  };
  // Every image once, on two threads (this machine's cores); the experiments reuse the features.
  std::vector<std::string> images;
  if (corridor_) {
    images.insert(images.end(), corridor_->refs.begin(), corridor_->refs.end());
    images.insert(images.end(), corridor_->queries.begin(), corridor_->queries.end());
  }
  if (triplets_) {
    for (const auto& place : triplets_->images)
      images.insert(images.end(), place.begin(), place.end());
  }
  for (const auto* seq : {kitti_ ? &*kitti_ : nullptr, bonn_ ? &*bonn_ : nullptr}) {
    if (seq == nullptr) continue;
    for (const PosedFrame& f : seq->frames) images.push_back(f.path);
  }
  std::cerr << "extracting features of " << images.size() << " images...\n";
  if (!check(cache_.Prefetch(images, kThreads))) return false;
  std::cerr << absl::StrFormat("  %.1f s\n", SecondsSince(start));
  std::cerr << "enrolling databases...\n";
  if (corridor_) {
    if (!check(AddGroup(kCorridor, "corridor: 111 refs enrolled, 111 queries",
                        {CorridorAll(*corridor_)})))
      return false;
    if (!check(AddGroup(kCorridorUnknown,
                        "corridor: refs 0-54 enrolled; queries with GT in 0-52 known, in 60-110 "
                        "unknown",
                        {CorridorPartial(*corridor_)})))
      return false;
  }
  if (corridor_) {
    if (!check(AddGroup(kCorridorSegments,
                        absl::StrCat("corridor cut into stretches of ", kSegment,
                                     " refs (one place each), queries in traversal order"),
                        {CorridorSegments(*corridor_, kSegment)})))
      return false;
  }
  if (triplets_) {
    if (!check(AddGroup(kTriplets, "triplets: 1 image per place enrolled, 2 queried, 3 folds",
                        TripletFolds(*triplets_))))
      return false;
    if (!check(AddGroup(kTripletsUnknown,
                        "triplets: p0-p4 enrolled (1 image), p5-p9 unknown, 3 folds",
                        TripletUnknownFolds(*triplets_))))
      return false;
  }
  if (corridor_ && triplets_) {
    if (!check(AddGroup(kCorridorVsTriplets, "111 corridor queries vs the 30 triplet images",
                        {CorridorQueriesVsTripletDb(*corridor_, *triplets_)})))
      return false;
    if (!check(AddGroup(kTripletsVsCorridor, "30 triplet images vs the 111 corridor refs",
                        {TripletQueriesVsCorridorDb(*corridor_, *triplets_)})))
      return false;
  }
  auto add_sequence = [&](const FrameSequence& seq, const std::string& dataset, const int* strides,
                          size_t n) {
    for (size_t i = 0; i < n; ++i) {
      Group extra;
      extra.off_position = true;
      extra.dataset = dataset;
      extra.stride = strides[i];
      extra.spacing_m = EnrolledSpacing(seq, strides[i]);
      const std::string name = absl::StrCat(dataset, "_every", strides[i]);
      if (!check(AddGroup(name,
                          absl::StrCat(seq.name, ": one frame in ", strides[i],
                                       " enrolled, the frames between queried"),
                          {OffPosition(seq, strides[i], kTolerance)}, std::move(extra))))
        return false;
    }
    return true;
  };
  if (kitti_ && !add_sequence(*kitti_, "kitti", kKittiStrides, std::size(kKittiStrides))) {
    return false;
  }
  if (bonn_ && !add_sequence(*bonn_, "bonn", kBonnStrides, std::size(kBonnStrides))) return false;
  load_seconds_ = SecondsSince(start);
  std::cerr << absl::StrFormat(
      "features: %d images, loaded and enrolled in %.1f s (%.1f s of "
      "extraction over %d threads), %.0f keypoints per image on average\n",
      cache_.size(), load_seconds_, cache_.extraction_seconds(), kThreads, cache_.mean_keypoints());
  return !groups_.empty();
}

std::vector<std::string> Evaluation::AllGroups() const {
  std::vector<std::string> names;
  for (const Group& g : groups_) names.push_back(g.name);
  return names;
}

std::vector<std::string> Evaluation::GroupsOf(const std::string& dataset) const {
  std::vector<std::string> names;
  for (const Group& g : groups_) {
    if (g.dataset == dataset) names.push_back(g.name);
  }
  return names;
}

std::vector<std::pair<std::string, std::vector<std::string>>> Evaluation::AccuracySets() const {
  std::vector<std::pair<std::string, std::vector<std::string>>> sets;
  if (corridor_) sets.push_back({"corridor R@1", {kCorridor}});
  if (triplets_) sets.push_back({"triplets", {kTriplets}});
  if (kitti_) sets.push_back({"KITTI off-position", GroupsOf("kitti")});
  if (bonn_) sets.push_back({"Bonn off-position", GroupsOf("bonn")});
  return sets;
}

std::vector<std::string> Evaluation::UnknownSets() const {
  std::vector<std::string> sets;
  if (corridor_) sets.push_back(kCorridorUnknown);
  if (triplets_) sets.push_back(kTripletsUnknown);
  if (corridor_ && triplets_) {
    sets.push_back(kCorridorVsTriplets);
    sets.push_back(kTripletsVsCorridor);
  }
  return sets;
}

double Evaluation::MeanAccuracy(const Run& run) const {
  double sum = 0;
  int n = 0;
  for (const auto& [label, groups] : AccuracySets()) {
    if (auto t = run.TallyOf(groups)) {
      sum += t->accuracy();
      ++n;
    }
  }
  return n ? sum / n : 0;
}

double Evaluation::WorstFalseAccept(const Run& run) const {
  double worst = 0;
  for (const std::string& g : UnknownSets()) {
    if (auto t = run.TallyOf({g}); t && t->unknown > 0)
      worst = std::max(worst, t->false_accept_rate());
  }
  return worst;
}

Run Evaluation::Execute(const std::string& label, const RecognitionOptions& options,
                        const std::vector<std::string>& groups) {
  Run run;
  run.label = label;
  run.options = options;
  for (const Group& g : groups_) {
    if (std::find(groups.begin(), groups.end(), g.name) == groups.end()) continue;
    const auto start = Clock::now();
    absl::StatusOr<std::vector<QueryOutcome>> o = RunQueries(g.parts, options);
    const double s = SecondsSince(start);
    if (!o.ok()) {
      std::cerr << "error in " << g.name << ": " << o.status().message() << "\n";
      continue;
    }
    run.outcomes[g.name] = *std::move(o);
    run.seconds[g.name] = s;
    const Tally t = Summarize(run.outcomes[g.name]);
    std::cerr << absl::StrFormat("  [%s] %-24s %4d queries  acc %-8s FA %-8s %6.1f s\n", label,
                                 g.name, t.queries, Pct(t.accuracy()), Pct(t.false_accept_rate()),
                                 s);
  }
  return run;
}

std::vector<std::string> Evaluation::PaperSweepGroups() const { return AllGroups(); }

// Global retrieval alone (VLAD of dense RootSIFT, vocabulary of `words` trained on the
// database's views, as the retrieval mode's global stage): R@1 and R@5 of the cosine-nearest
// views, per group, no verification. The vocabulary learns from `sample_rows` dense descriptors
// of each view (EvenRows, what the service keeps), or from up to 50,000 spread over all (0).
void Evaluation::VladReport(int words, int sample_rows) {
  for (const Group& g : groups_) {
    if (g.name != kCorridor && g.name != kTriplets && g.name != kCorridorSegments) continue;
    int queries = 0, top1 = 0, top5 = 0;
    for (const PreparedProtocol& part : g.parts) {
      std::vector<cv::Mat> dense;
      std::vector<cv::Mat> samples;
      for (const Enrollment& e : part.protocol.enroll) {
        dense.push_back((*cache_.Get(e.path))->dense);
        samples.push_back(sample_rows > 0 ? crossing::EvenRows(dense.back(), sample_rows)
                                          : dense.back());
      }
      const crossing::VladVocabulary vocabulary =
          crossing::VladVocabulary::TrainOnImages(samples, words);
      std::vector<cv::Mat> views;
      for (const cv::Mat& d : dense) views.push_back(vocabulary.Encode(d));
      for (size_t q = 0; q < part.protocol.queries.size(); ++q) {
        const Query& query = part.protocol.queries[q];
        if (query.accepted.empty()) continue;
        const cv::Mat v = vocabulary.Encode(part.query_features[q]->dense);
        std::vector<std::pair<double, size_t>> ranked;
        for (size_t i = 0; i < views.size(); ++i) ranked.push_back({-v.dot(views[i]), i});
        std::sort(ranked.begin(), ranked.end());
        ++queries;
        for (size_t r = 0; r < std::min<size_t>(5, ranked.size()); ++r) {
          const int64_t place = part.protocol.enroll[ranked[r].second].place;
          if (std::find(query.accepted.begin(), query.accepted.end(), place) !=
              query.accepted.end()) {
            top1 += r == 0;
            ++top5;
            break;
          }
        }
      }
    }
    std::cerr << absl::StrFormat("  [vlad %d, %s] %-24s R@1 %s  R@5 %s\n", words,
                                 sample_rows > 0 ? absl::StrCat(sample_rows, " rows/view")
                                                 : std::string("all rows"),
                                 g.name,
                                 Pct(queries ? double(top1) / queries : NAN),
                                 Pct(queries ? double(top5) / queries : NAN));
  }
}

void Evaluation::AcceptanceDump(const std::string& path, int vocabulary_rows) {
  if (vocabulary_rows > 0) {
    for (Group& g : groups_) {
      for (PreparedProtocol& part : g.parts) {
        std::vector<cv::Mat> dense;
        for (const Enrollment& e : part.protocol.enroll) {
          dense.push_back((*cache_.Get(e.path))->dense);
        }
        part.db->TrainGlobal(dense, crossing::kVladWords, vocabulary_rows);
      }
    }
  }
  // The null distribution a database offers itself: each view as a query against the views of
  // the other places (its own place left out), top similarity minus median.
  {
    std::ofstream null_out(path + ".null.csv");
    null_out << "group,part,slot,top,median\n";
    for (const Group& g : groups_) {
      for (size_t p = 0; p < g.parts.size(); ++p) {
        const crossing::ViewDatabase& db = *g.parts[p].db;
        if (db.global_index().empty()) continue;
        for (uint32_t v = 0; v < db.views().size(); ++v) {
          const std::vector<float> sims = db.global_index().Similarities(db.global_code(v));
          std::vector<float> others;
          for (uint32_t o = 0; o < sims.size(); ++o) {
            if (db.views()[o].crossing_id != db.views()[v].crossing_id) others.push_back(sims[o]);
          }
          if (others.empty()) continue;
          std::sort(others.begin(), others.end());
          null_out << absl::StrFormat("%s,%d,%d,%.5f,%.5f\n", g.name, p, v, others.back(),
                                      others[others.size() / 2]);
        }
      }
    }
  }
  std::ofstream out(path);
  out << "group,part,query,known,slot,place,correct,inliers,tentative,log10_nfa,global_sim,"
         "global_z,top_sim,top_place_correct,other_place_sim,median_sim,views\n";
  RecognitionOptions options;
  options.mode = RecognitionMode::kRetrieval;
  options.max_log10_nfa = 100;  // every winner: the rule is applied afterwards
  for (const Group& g : groups_) {
    for (size_t p = 0; p < g.parts.size(); ++p) {
      const PreparedProtocol& part = g.parts[p];
      const crossing::ViewDatabase& db = *part.db;
      for (size_t q = 0; q < part.protocol.queries.size(); ++q) {
        const Query& query = part.protocol.queries[q];
        const crossing::ImageFeatures& f = *part.query_features[q];
        auto is_correct = [&](int64_t place) {
          return std::find(query.accepted.begin(), query.accepted.end(), place) !=
                 query.accepted.end();
        };
        std::vector<float> sims;
        if (!db.global_index().empty() && !f.dense.empty()) {
          sims = db.global_index().Similarities(
              crossing::QuantizeGlobal(db.vocabulary().Encode(f.dense)));
        }
        double top = 0, other = 0, median = 0;
        int64_t top_place = -1;
        if (!sims.empty()) {
          const auto ranked = crossing::TopSimilar(sims, static_cast<int>(sims.size()));
          top = ranked[0].first;
          top_place = db.views()[ranked[0].second].crossing_id;
          for (const auto& [sim, slot] : ranked) {
            if (db.views()[slot].crossing_id != top_place) {
              other = sim;
              break;
            }
          }
          median = ranked[ranked.size() / 2].first;
        }
        absl::StatusOr<crossing::Recognition> r = crossing::Recognize(db, f, options);
        if (!r.ok()) continue;
        if (r->candidates.empty()) {  // still a row: the global stage alone may answer it
          out << absl::StrFormat("%s,%d,%d,%d,-1,-1,0,0,0,0,0,0,%.5f,%d,%.5f,%.5f,%d\n", g.name, p,
                                 q, !query.accepted.empty(), top, is_correct(top_place), other,
                                 median, db.views().size());
        }
        for (const crossing::Candidate& c : r->candidates) {
          const int64_t place = db.views()[c.slot].crossing_id;
          out << absl::StrFormat("%s,%d,%d,%d,%d,%d,%d,%d,%d,%.4f,%.5f,%.3f,%.5f,%d,%.5f,%.5f,%d\n",
                                 g.name, p, q, !query.accepted.empty(), c.slot, place,
                                 is_correct(place), c.matches, c.tentative, c.log10_nfa,
                                 c.global_similarity, c.global_z, top, is_correct(top_place),
                                 other, median, db.views().size());
        }
      }
    }
  }
  std::cerr << "wrote the acceptance data to " << path << "\n";
}

// StreamRecognize's evidence filter replayed over a query traversal streamed in order: how often
// its answer is right or wrong, and how many frames after entering a stretch it names it.
std::string Evaluation::SequenceReport(const Run& run, double threshold) const {
  const std::vector<QueryOutcome>* outcomes = run.Get(kCorridorSegments);
  const Group* group = nullptr;
  for (const Group& g : groups_) {
    if (g.name == kCorridorSegments) group = &g;
  }
  if (outcomes == nullptr || group == nullptr) return "";
  const std::vector<Query>& queries = group->parts.front().protocol.queries;
  crossing::EvidenceOptions options;
  options.threshold = threshold;
  crossing::PlaceEvidenceFilter filter(options);
  int decided = 0, decided_right = 0, single_right = 0, single_accepted = 0, single_wrong = 0;
  std::vector<int> delays;
  int runs = 0, runs_named = 0;
  int64_t run_place = -1;
  int run_start = 0;
  bool run_named = false;
  for (size_t i = 0; i < outcomes->size() && i < queries.size(); ++i) {
    const QueryOutcome& o = (*outcomes)[i];
    std::vector<crossing::FrameEvidence> frame;
    for (const auto& [place, nfa] : o.evidence) frame.push_back({place, nfa});
    const crossing::PlaceBelief& b = filter.Update(frame);
    const std::vector<int64_t>& accepted = queries[i].accepted;
    const bool right = b.recognized && std::find(accepted.begin(), accepted.end(), b.crossing_id) != accepted.end();
    decided += b.recognized;
    decided_right += right;
    single_right += o.correct();
    single_accepted += o.recognized;
    single_wrong += o.recognized && !o.winner_correct;
    // A stretch is entered when the query's first accepted place changes.
    if (accepted.empty()) continue;
    const int64_t place = accepted.back();
    if (place != run_place) {
      if (run_place >= 0) runs_named += run_named;
      ++runs;
      run_place = place;
      run_start = static_cast<int>(i);
      run_named = false;
    }
    if (!run_named && b.recognized && b.crossing_id == place) {
      run_named = true;
      delays.push_back(static_cast<int>(i) - run_start + 1);
    }
  }
  runs_named += run_named;
  std::sort(delays.begin(), delays.end());
  const int n = static_cast<int>(outcomes->size());
  const double median = delays.empty() ? NAN : delays[delays.size() / 2];
  return absl::StrFormat(
      "threshold %.2f: frames alone right %d/%d (accepted %d, wrong %d); with evidence answered "
      "%d/%d frames, right %d, wrong %d; %d/%d stretches named, median %.0f frames after "
      "entering (max %d)",
      threshold, single_right, n, single_accepted, single_wrong, decided, n, decided_right,
      decided - decided_right, runs_named, runs, median, delays.empty() ? 0 : delays.back());
}

void Evaluation::RunAll() {
  const auto start = Clock::now();
  RecognitionOptions paper;
  paper.mode = RecognitionMode::kPaper;
  RecognitionOptions verified;
  verified.mode = RecognitionMode::kVerified;

  std::cerr << "paper mode, defaults:\n";
  paper_ = Execute("paper", paper, AllGroups());
  std::cerr << "verified mode, defaults:\n";
  verified_ = Execute("verified", verified, AllGroups());

  {
    RecognitionOptions o;
    o.mode = RecognitionMode::kRetrieval;
    const std::vector<double> limits =
        quick_ ? std::vector<double>{-2.0, 0.0} : std::vector<double>{-4.0, -2.0, 0.0, 2.0};
    for (double nfa : limits) {
      o.max_log10_nfa = nfa;
      std::cerr << "retrieval mode, max_log10_nfa " << nfa << ":\n";
      retrieval_.push_back(Execute(absl::StrFormat("retrieval nfa %g", nfa), o, AllGroups()));
    }
    // The global path's threshold (RecognitionOptions::min_global_lift; the runs above use the
    // default), 0 = the NFA alone.
    o.max_log10_nfa = 0.0;
    for (double lift : {0.0, 0.14, 0.18}) {
      o.min_global_lift = lift;
      std::cerr << "retrieval mode, max_log10_nfa 0, min_global_lift " << lift << ":\n";
      retrieval_.push_back(
          Execute(absl::StrFormat("retrieval nfa 0 lift %g", lift), o, AllGroups()));
    }
  }

  for (const Run& r : retrieval_) {
    if (r.options.max_log10_nfa != 0.0 ||
        r.options.min_global_lift != RecognitionOptions().min_global_lift) {
      continue;
    }
    for (double threshold : {0.8, 0.95, 0.99}) {
      sequence_.push_back(SequenceReport(r, threshold));
      std::cerr << "stream over the corridor, " << sequence_.back() << "\n";
    }
  }
  for (int words : {64, 128}) VladReport(words, 0);
  VladReport(crossing::kVladWords, crossing::kVocabularySampleRows);
  if (quick_) return;
  // The hue term of the decision can overrule the geometric evidence: the same run without it.
  {
    RecognitionOptions o = verified;
    o.alpha = 1.0;
    o.beta = 0.0;
    std::cerr << "verified mode, alpha 1 beta 0 (inliers only):\n";
    verified_inliers_only_ = Execute("verified alpha 1", o, AllGroups());
  }

  // Paper-mode ratio sweep (lambda); 0.32 is the defaults run above.
  for (double ratio : {0.32, 0.5, 0.6, 0.7, 0.8}) {
    if (ratio == paper.ratio) {
      Run r = paper_;
      r.label = absl::StrFormat("paper ratio %.2f", ratio);
      paper_sweep_.push_back(std::move(r));
      continue;
    }
    std::cerr << absl::StrFormat("paper mode, ratio %.2f:\n", ratio);
    RecognitionOptions o = paper;
    o.ratio = ratio;
    paper_sweep_.push_back(
        Execute(absl::StrFormat("paper ratio %.2f", ratio), o, PaperSweepGroups()));
  }

  // Verified-mode rejection rule sweep. min_inliers changes the candidates (the engine does not
  // verify views with fewer tentative matches than min_inliers), so the engine runs once per
  // min_inliers, with min_inlier_share = 0; the share only filters the decision's winner
  // afterwards, so it is replayed on those outcomes (ReplayRejectionRule), and the replay is
  // checked against the engine's own run at the defaults.
  std::map<int, Run> base;
  for (int mi : {0, 8, 10, 12, 15, 20, 25, 30}) {
    RecognitionOptions o = verified;
    o.min_inliers = mi;
    o.min_inlier_share = 0;
    std::cerr << "verified mode, min_inliers " << mi << ", min_inlier_share 0:\n";
    base[mi] = Execute(absl::StrFormat("verified %d/0", mi), o, AllGroups());
  }
  auto check_replay = [&](const Run& engine, const Run& replayed) {
    for (const auto& [g, outcomes] : engine.outcomes) {
      const auto it = replayed.outcomes.find(g);
      if (it == replayed.outcomes.end() || it->second.size() != outcomes.size()) {
        replay_mismatches_ += static_cast<int>(outcomes.size());
        replay_checked_ += static_cast<int>(outcomes.size());
        continue;
      }
      for (size_t i = 0; i < outcomes.size(); ++i) {
        ++replay_checked_;
        if (it->second[i].recognized != outcomes[i].recognized ||
            (outcomes[i].recognized && it->second[i].winner_place != outcomes[i].winner_place)) {
          ++replay_mismatches_;
        }
      }
    }
  };
  std::vector<std::pair<int, double>> grid = {{0, 0.0}};  // no rejection: the ceiling
  for (int mi : {8, 10, 12, 15, 20, 25, 30}) {
    for (double share : {0.1, 0.2, 0.3}) grid.push_back({mi, share});
  }
  for (const auto& [mi, share] : grid) {
    Run r = base.at(mi);
    r.label = absl::StrFormat("verified min_inliers %d share %.1f", mi, share);
    r.options.min_inlier_share = share;
    r.replayed = share > 0;
    for (auto& [g, outcomes] : r.outcomes) outcomes = ReplayRejectionRule(outcomes, mi, share);
    if (mi == verified.min_inliers && share == verified.min_inlier_share) {
      check_replay(verified_, r);
    }
    verified_sweep_.push_back(std::move(r));
  }
  // Operating point: worst false-accept rate over the unknown sets <= kMaxFalseAccept, then the
  // highest mean accuracy, then the smallest worst false-accept rate. Among points still tied
  // (they accept exactly as often), the current defaults stay if they are one of them, else the
  // strictest rule (most inliers, then largest share) is taken.
  auto is_default = [&](const RecognitionOptions& o) {
    return o.min_inliers == verified.min_inliers && o.min_inlier_share == verified.min_inlier_share;
  };
  auto stricter = [](const RecognitionOptions& a, const RecognitionOptions& b) {
    return a.min_inliers != b.min_inliers ? a.min_inliers > b.min_inliers
                                          : a.min_inlier_share > b.min_inlier_share;
  };
  for (size_t i = 1; i < verified_sweep_.size(); ++i) {
    const Run& r = verified_sweep_[i];
    if (WorstFalseAccept(r) > kMaxFalseAccept) continue;
    if (chosen_index_ < 0) {
      chosen_index_ = static_cast<int>(i);
      continue;
    }
    const Run& best = verified_sweep_[chosen_index_];
    const double a = MeanAccuracy(r), b = MeanAccuracy(best);
    const double fa = WorstFalseAccept(r), fb = WorstFalseAccept(best);
    bool better = false;
    if (a > b + 1e-12) {
      better = true;
    } else if (a >= b - 1e-12) {
      if (fa < fb - 1e-12) {
        better = true;
      } else if (fa <= fb + 1e-12 && !is_default(best.options)) {
        better = is_default(r.options) || stricter(r.options, best.options);
      }
    }
    if (better) chosen_index_ = static_cast<int>(i);
  }
  if (chosen_index_ >= 0) {
    const RecognitionOptions& c = verified_sweep_[chosen_index_].options;
    chosen_is_default_ =
        c.min_inliers == verified.min_inliers && c.min_inlier_share == verified.min_inlier_share;
    std::cerr << absl::StrFormat(
        "operating point: min_inliers %d, min_inlier_share %.1f (mean accuracy %s, worst "
        "false-accept %s)%s\n",
        c.min_inliers, c.min_inlier_share, Pct(MeanAccuracy(verified_sweep_[chosen_index_])),
        Pct(WorstFalseAccept(verified_sweep_[chosen_index_])),
        chosen_is_default_ ? " = the current defaults" : "");
    if (!chosen_is_default_) {
      // Run the chosen point through the engine as well: a second check of the replay.
      std::cerr << "verified mode, chosen operating point:\n";
      verified_chosen_ = Execute("verified chosen", c, AllGroups());
      check_replay(verified_chosen_, verified_sweep_[chosen_index_]);
    }
  }
  std::cerr << absl::StrFormat("rejection-rule replay vs engine: %d mismatches in %d queries\n",
                               replay_mismatches_, replay_checked_);
  total_seconds_ = SecondsSince(start) + load_seconds_;
  std::cerr << absl::StrFormat("total wall time %.1f s\n", total_seconds_);
}

json Evaluation::ToJson() const {
  json j;
  j["data"]["shared"] = shared_;
  j["data"]["images"] = cache_.size();
  j["data"]["mean_keypoints"] = cache_.mean_keypoints();
  j["data"]["missing"] = missing_;
  j["timing"]["load_and_extract_s"] = load_seconds_;
  j["timing"]["feature_extraction_s"] = cache_.extraction_seconds();
  j["timing"]["total_s"] = total_seconds_;
  for (const Group& g : groups_) {
    json gj;
    gj["description"] = g.description;
    size_t views = 0, clusters = 0, queries = 0;
    for (const auto& p : g.parts) {
      views += p.db->views().size();
      clusters += p.db->clusters().size();
      queries += p.protocol.queries.size();
    }
    gj["views"] = views;
    gj["clusters"] = clusters;
    gj["queries"] = queries;
    gj["parts"] = g.parts.size();
    if (g.off_position) {
      gj["stride"] = g.stride;
      gj["enrolled_spacing_m"] = g.spacing_m;
      gj["tolerance_m"] = kTolerance * g.spacing_m;
    }
    j["experiments"][g.name] = gj;
  }
  auto run_json = [&](const Run& r) {
    json rj;
    rj["label"] = r.label;
    rj["options"] = OptionsJson(r.options);
    rj["replayed"] = r.replayed;
    for (const auto& [g, outcomes] : r.outcomes) {
      json t = TallyJson(Summarize(outcomes));
      if (auto it = r.seconds.find(g); it != r.seconds.end()) t["wall_s"] = it->second;
      rj["results"][g] = t;
    }
    for (const auto& [label, groups] : AccuracySets()) {
      if (auto t = r.TallyOf(groups)) rj["summary"]["accuracy"][label] = Num(t->accuracy());
    }
    for (const std::string& g : UnknownSets()) {
      if (auto t = r.TallyOf({g})) rj["summary"]["false_accept"][g] = Num(t->false_accept_rate());
    }
    rj["summary"]["mean_accuracy"] = MeanAccuracy(r);
    rj["summary"]["worst_false_accept"] = WorstFalseAccept(r);
    return rj;
  };
  j["defaults"]["paper"] = run_json(paper_);
  j["defaults"]["verified"] = run_json(verified_);
  j["verified_inliers_only"] = run_json(verified_inliers_only_);
  for (const Run& r : retrieval_) j["retrieval"].push_back(run_json(r));
  for (const Run& r : paper_sweep_) j["paper_ratio_sweep"].push_back(run_json(r));
  for (const Run& r : verified_sweep_) j["verified_rule_sweep"].push_back(run_json(r));
  if (chosen_index_ >= 0) {
    j["operating_point"]["min_inliers"] = verified_sweep_[chosen_index_].options.min_inliers;
    j["operating_point"]["min_inlier_share"] =
        verified_sweep_[chosen_index_].options.min_inlier_share;
    j["operating_point"]["criterion"] = absl::StrFormat(
        "false accepts <= %.0f %% on every unknown set, then the highest mean "
        "accuracy",
        100 * kMaxFalseAccept);
    j["operating_point"]["equals_defaults"] = chosen_is_default_;
    if (!chosen_is_default_) j["operating_point"]["engine_run"] = run_json(verified_chosen_);
  }
  j["replay_check"]["queries"] = replay_checked_;
  j["replay_check"]["mismatches"] = replay_mismatches_;
  return j;
}

std::string Evaluation::MainTable() const {
  std::ostringstream md;
  md << "| experiment | queries (known / unknown) | paper: accuracy | paper: precision | "
        "paper: false accepts | verified: accuracy | verified: precision | verified: false "
        "accepts | ms/query paper / verified |\n";
  md << "|---|---|---|---|---|---|---|---|---|\n";
  for (const Group& g : groups_) {
    const auto* po = paper_.Get(g.name);
    const auto* vo = verified_.Get(g.name);
    if (!po || !vo) continue;
    const Tally p = Summarize(*po), v = Summarize(*vo);
    auto fa = [](const Tally& t) {
      return t.unknown ? absl::StrCat(Pct(t.false_accept_rate()), " (", t.false_accepts, ")")
                       : std::string("-");
    };
    auto acc = [](const Tally& t) {
      return t.known ? absl::StrCat(Pct(t.accuracy()), " (", Frac(t.correct, t.known), ")")
                     : std::string("-");
    };
    md << "| " << g.name << " | " << p.known << " / " << p.unknown << " | " << acc(p) << " | "
       << Pct(p.precision()) << " | " << fa(p) << " | " << acc(v) << " | " << Pct(v.precision())
       << " | " << fa(v) << " | " << absl::StrFormat("%.1f / %.1f", p.mean_ms(), v.mean_ms())
       << " |\n";
  }
  return md.str();
}

std::string Evaluation::OffPositionTables() const {
  std::ostringstream md;
  struct Bin {
    double lo, hi;
  };
  auto bins_for = [](const std::string& dataset) {
    if (dataset == "kitti") {
      return std::vector<Bin>{{0, 1.5}, {1.5, 3.0}, {3.0, 4.5}, {4.5, 1e9}};
    }
    return std::vector<Bin>{{0, 0.01}, {0.01, 0.02}, {0.02, 0.04}, {0.04, 1e9}};
  };
  auto bin_label = [](const std::string& dataset, const Bin& b) {
    const bool cm = dataset != "kitti";
    const double k = cm ? 100 : 1;
    const std::string unit = cm ? " cm" : " m";
    if (b.hi > 1e8) return absl::StrFormat(">= %.1f%s", b.lo * k, unit);
    return absl::StrFormat("%.1f-%.1f%s", b.lo * k, b.hi * k, unit);
  };
  std::vector<const Run*> runs = {&paper_, &verified_};
  const Run* loose = paper_sweep_.empty() ? nullptr : &paper_sweep_.back();
  if (loose) runs.insert(runs.begin() + 1, loose);
  if (!chosen_is_default_ && chosen_index_ >= 0) runs.push_back(&verified_chosen_);

  for (const std::string dataset : {"kitti", "bonn"}) {
    const std::vector<std::string> groups = GroupsOf(dataset);
    if (groups.empty()) continue;
    const bool kitti = dataset == std::string("kitti");
    md << "\n**" << (kitti ? "KITTI odometry 06, frames 0-50" : "Bonn RGB-D crowd, frames 270-409")
       << "**: per enrolment stride (spacing = median distance between consecutive enrolled "
          "frames). Accuracy = recognized as the nearest enrolled frame or one at most half a "
          "spacing farther; \"nearest\" = strictly the nearest; \"around\" = one of the two "
          "enrolled frames around the query in time; \"wrong\" = recognized as another frame.\n\n";
    md << "| stride | spacing | queries |";
    for (const Run* r : runs) md << " " << r->label << ": acc / nearest / around / wrong |";
    md << "\n|---|---|---|";
    for (size_t i = 0; i < runs.size(); ++i) md << "---|";
    md << "\n";
    for (const Group& g : groups_) {
      if (g.dataset != dataset) continue;
      const std::string spacing = kitti ? absl::StrFormat("%.1f m", g.spacing_m)
                                        : absl::StrFormat("%.1f cm", 100 * g.spacing_m);
      md << "| " << g.stride << " | " << spacing << " | ";
      const auto* any = paper_.Get(g.name);
      md << (any ? any->size() : 0) << " |";
      for (const Run* r : runs) {
        const auto* o = r->Get(g.name);
        if (!o) {
          md << " - |";
          continue;
        }
        const Tally t = Summarize(*o);
        md << " " << Pct(t.accuracy()) << " / "
           << Pct(t.known ? double(t.correct_nearest) / t.known : NAN) << " / "
           << Pct(t.known ? double(t.correct_bracket) / t.known : NAN) << " / "
           << Pct(t.wrong_rate()) << " |";
      }
      md << "\n";
    }
    md << "\nAccuracy vs distance to the nearest enrolled frame (all strides pooled):\n\n";
    md << "| distance | queries |";
    for (const Run* r : runs) md << " " << r->label << " |";
    md << "\n|---|---|";
    for (size_t i = 0; i < runs.size(); ++i) md << "---|";
    md << "\n";
    for (const Bin& b : bins_for(dataset)) {
      std::string row;
      int n = 0;
      for (const Run* r : runs) {
        std::vector<QueryOutcome> in_bin;
        for (const auto& o : r->Pool(groups)) {
          if (o.distance_m >= b.lo && o.distance_m < b.hi) in_bin.push_back(o);
        }
        n = static_cast<int>(in_bin.size());
        const Tally t = Summarize(in_bin);
        row += absl::StrCat(" ", Pct(t.accuracy()), " |");
      }
      if (n == 0) continue;
      md << "| " << bin_label(dataset, b) << " | " << n << " |" << row << "\n";
    }
    if (!kitti) {
      md << "\nBonn accuracy vs rotation to the nearest enrolled frame (all strides pooled):\n\n";
      md << "| rotation | queries |";
      for (const Run* r : runs) md << " " << r->label << " |";
      md << "\n|---|---|";
      for (size_t i = 0; i < runs.size(); ++i) md << "---|";
      md << "\n";
      for (const Bin& b : std::vector<Bin>{{0, 2}, {2, 5}, {5, 10}, {10, 1e9}}) {
        std::string row;
        int n = 0;
        for (const Run* r : runs) {
          std::vector<QueryOutcome> in_bin;
          for (const auto& o : r->Pool(groups)) {
            if (o.angle_deg >= b.lo && o.angle_deg < b.hi) in_bin.push_back(o);
          }
          n = static_cast<int>(in_bin.size());
          row += absl::StrCat(" ", Pct(Summarize(in_bin).accuracy()), " |");
        }
        if (n == 0) continue;
        const std::string label = b.hi > 1e8 ? absl::StrFormat(">= %.0f deg", b.lo)
                                             : absl::StrFormat("%.0f-%.0f deg", b.lo, b.hi);
        md << "| " << label << " | " << n << " |" << row << "\n";
      }
    }
  }
  return md.str();
}

// The columns both sweep tables share: accuracy per known set, then false accepts per unknown set.
std::string Evaluation::SweepHeader(const std::string& leading, const std::string& trailing,
                                    int extra_columns) const {
  std::ostringstream md;
  md << "| " << leading << " |";
  for (const auto& [label, groups] : AccuracySets()) md << " " << label << " |";
  if (corridor_) md << " corridor_unknown: known acc |";
  for (const std::string& g : UnknownSets()) md << " FA " << g << " |";
  md << trailing << "\n|";
  const size_t columns =
      1 + AccuracySets().size() + UnknownSets().size() + (corridor_ ? 1 : 0) + extra_columns;
  for (size_t i = 0; i < columns; ++i) md << "---|";
  md << "\n";
  return md.str();
}

std::string Evaluation::SweepCells(const Run& r) const {
  std::ostringstream md;
  for (const auto& [label, groups] : AccuracySets()) {
    md << " " << Pct(r.TallyOf(groups)->accuracy()) << " |";
  }
  if (corridor_) md << " " << Pct(r.TallyOf({kCorridorUnknown})->accuracy()) << " |";
  for (const std::string& g : UnknownSets()) {
    md << " " << Pct(r.TallyOf({g})->false_accept_rate()) << " |";
  }
  return md.str();
}

std::string Evaluation::PaperSweepTable() const {
  std::ostringstream md;
  md << SweepHeader("ratio (lambda)", " ms/query (corridor) |", 1);
  for (const Run& r : paper_sweep_) {
    md << "| " << absl::StrFormat("%.2f", r.options.ratio) << " |" << SweepCells(r);
    if (auto t = r.TallyOf({kCorridor})) {
      md << absl::StrFormat(" %.1f |", t->mean_ms());
    } else {
      md << " - |";
    }
    md << "\n";
  }
  return md.str();
}

std::string Evaluation::VerifiedSweepTable() const {
  std::ostringstream md;
  md << SweepHeader("min_inliers | min_inlier_share", " mean accuracy | worst FA |", 3);
  for (size_t i = 0; i < verified_sweep_.size(); ++i) {
    const Run& r = verified_sweep_[i];
    const bool chosen = static_cast<int>(i) == chosen_index_;
    const bool is_default = r.options.min_inliers == RecognitionOptions{}.min_inliers &&
                            r.options.min_inlier_share == RecognitionOptions{}.min_inlier_share;
    std::string mark = chosen ? " **(chosen)**" : "";
    if (is_default) mark += " (defaults)";
    if (r.options.min_inliers == 0 && r.options.min_inlier_share == 0) mark = " (no rejection)";
    md << "| " << r.options.min_inliers << mark << " | "
       << absl::StrFormat("%.1f", r.options.min_inlier_share) << " |" << SweepCells(r);
    md << " " << Pct(MeanAccuracy(r)) << " | " << Pct(WorstFalseAccept(r)) << " |\n";
  }
  return md.str();
}

std::string Evaluation::DecisionWeightsTable() const {
  std::ostringstream md;
  md << "| set | verified (alpha = beta = 0.5) | verified, alpha = 1, beta = 0 |\n|---|---|---|\n";
  for (const auto& [label, groups] : AccuracySets()) {
    md << "| " << label << ": accuracy | " << Pct(verified_.TallyOf(groups)->accuracy()) << " | "
       << Pct(verified_inliers_only_.TallyOf(groups)->accuracy()) << " |\n";
  }
  for (const std::string& g : UnknownSets()) {
    md << "| " << g << ": false accepts | " << Pct(verified_.TallyOf({g})->false_accept_rate())
       << " | " << Pct(verified_inliers_only_.TallyOf({g})->false_accept_rate()) << " |\n";
  }
  return md.str();
}

std::string Evaluation::ToMarkdown() const {
  std::ostringstream md;
  const RecognitionOptions d;
  md << "# Crossing recognition on real place-recognition data\n\n";
  md << absl::StrFormat(
      "Generated by `waymark-vpr-eval` from `%s/data` (read in place). %d images, features "
      "extracted once at 320x240 (%.1f s of extraction on %d threads, %.0f SIFT keypoints per "
      "image on average); loading + enrolling %.0f s, total wall time %.0f s.\n\n",
      shared_, cache_.size(), cache_.extraction_seconds(), kThreads, cache_.mean_keypoints(),
      load_seconds_, total_seconds_);
  for (const std::string& m : missing_) md << "- missing: " << m << "\n";
  md << absl::StrFormat(
      "Paper mode: ratio %.2f, N0 %d, N1 %d, N2 %d, alpha = beta = %.1f. Verified mode: ratio "
      "%.2f, shortlist %d, RANSAC %.1f px, rejection rule min_inliers %d and min_inlier_share "
      "%.1f. Every view is enrolled as its own place with the paper's clustering (threshold "
      "5).\n\n",
      d.ratio, d.n0, d.n1, d.n2, d.alpha, d.verified_ratio, d.shortlist, d.ransac_threshold_px,
      d.min_inliers, d.min_inlier_share);

  md << "## Retrieval mode (a-contrario acceptance, global path) at several limits\n\n";
  md << "Precision (correct / accepted) is given for the defaults (nfa 0, lift "
     << RecognitionOptions().min_global_lift << ").\n\n";
  md << "| set | queries | precision at the defaults | ";
  for (const Run& r : retrieval_) md << r.label << ": accuracy | false accepts | ";
  md << "\n|---|---|---|";
  for (size_t i = 0; i < retrieval_.size(); ++i) md << "---|---|";
  md << "\n";
  const Run* defaults = nullptr;
  for (const Run& r : retrieval_) {
    if (r.options.max_log10_nfa == RecognitionOptions().max_log10_nfa &&
        r.options.min_global_lift == RecognitionOptions().min_global_lift && !defaults) {
      defaults = &r;
    }
  }
  for (const Group& g : groups_) {
    if (retrieval_.empty() || retrieval_.front().Get(g.name) == nullptr) continue;
    md << "| " << g.name << " | " << retrieval_.front().Get(g.name)->size() << " | "
       << (defaults && defaults->Get(g.name) ? Pct(Summarize(*defaults->Get(g.name)).precision())
                                             : std::string("-"))
       << " | ";
    for (const Run& r : retrieval_) {
      const Tally t = Summarize(*r.Get(g.name));
      md << Pct(t.accuracy()) << " | " << Pct(t.false_accept_rate()) << " | ";
    }
    md << "\n";
  }
  md << "\nEvidence over frames (StreamRecognize's filter replayed on the corridor query traversal "
        "in order, places = stretches of " << kSegment << " refs, retrieval mode at "
        "max_log10_nfa 0):\n\n";
  for (const std::string& line : sequence_) md << "- " << line << "\n";
  md << "\n";

  md << "## Both modes at their defaults\n\n";
  md << "Accuracy = correct / known queries (not recognized counts as wrong); precision = correct "
        "/ accepted; false accepts = accepted unknown queries / unknown queries.\n\n";
  md << MainTable();
  md << "\nExperiments:\n\n";
  for (const Group& g : groups_) {
    size_t views = 0, clusters = 0;
    for (const auto& p : g.parts) {
      views += p.db->views().size();
      clusters += p.db->clusters().size();
    }
    md << "- `" << g.name << "`: " << g.description << " (" << views << " views in " << clusters
       << " clusters over " << g.parts.size() << " database(s)";
    auto ps = paper_.seconds.find(g.name);
    auto vs = verified_.seconds.find(g.name);
    if (ps != paper_.seconds.end() && vs != verified_.seconds.end()) {
      md << absl::StrFormat("; wall time paper %.1f s, verified %.1f s", ps->second, vs->second);
    }
    md << ")\n";
  }

  if (corridor_) {
    md << "\n## Corridor recall@1 against the published methods\n\n";
    md << "| method | R@1 |\n|---|---|\n";
    const Tally p = *paper_.TallyOf({kCorridor});
    const Tally v = *verified_.TallyOf({kCorridor});
    md << "| HybridNet (VPR-Bench) | 90.1 % |\n| AMOSNet | 84.7 % |\n| denseVLAD | 70.3 % |\n"
          "| AlexNet | 69.4 % |\n| NetVLAD | 67.6 % |\n| HOG | 47.8 % |\n";
    md << "| Waymark paper mode | " << Pct(p.accuracy()) << " (precision " << Pct(p.precision())
       << ") |\n";
    md << "| Waymark verified mode | " << Pct(v.accuracy()) << " (precision " << Pct(v.precision())
       << ") |\n";
    md << "\n(Published numbers: `reference_results_from_vprbench_precomputed.csv`, best match "
          "over all refs, no rejection. Waymark may reject a query; a rejection counts as "
          "wrong.)\n";
  }

  if (kitti_ || bonn_) {
    md << "\n## Queries away from the enrolled positions\n";
    md << OffPositionTables();
  }
  md << "\n## Paper mode: ratio sweep\n\n";
  md << "Accuracy on the known sets and false accepts (FA) on the unknown sets; clustering keeps "
        "the paper's ratio 0.32.\n\n";
  md << PaperSweepTable();
  md << "\n## Verified mode: rejection-rule sweep\n\n";
  md << absl::StrFormat(
      "The rule: the decision's winner needs min_inliers epipolar inliers and min_inlier_share "
      "of its tentative matches (and the engine does not verify views with fewer tentative "
      "matches than min_inliers). One engine run per min_inliers with min_inlier_share 0; the "
      "share is applied to those outcomes afterwards, which agrees with the engine's own run at "
      "the defaults on %d of %d queries. Operating point: false accepts <= %.0f %% on every "
      "unknown set, then the "
      "highest mean accuracy over the known sets.\n\n",
      replay_checked_ - replay_mismatches_, replay_checked_, 100 * kMaxFalseAccept);
  md << VerifiedSweepTable();
  if (chosen_index_ >= 0) {
    const RecognitionOptions& c = verified_sweep_[chosen_index_].options;
    md << absl::StrFormat(
        "\nChosen: min_inliers %d, min_inlier_share %.1f%s.\n", c.min_inliers, c.min_inlier_share,
        chosen_is_default_ ? " (the current defaults)" : " (differs from the defaults)");
  } else {
    md << "\nNo grid point keeps every unknown set under the false-accept ceiling.\n";
  }
  md << "\n## Verified mode: the hue term\n\n";
  md << "The decision (alpha * M / M_max + beta * S / S_max) may pick a view with fewer inliers "
        "than the best one, and the rejection rule then judges that view. The same run with the "
        "hue term left out:\n\n";
  md << DecisionWeightsTable();
  return md.str();
}

}  // namespace
}  // namespace waymark::vpr

int main(int argc, char** argv) {
  CLI::App app{"Crossing recognition on real place-recognition data (../shared/data)"};
  std::string shared = "../shared";
  std::string out_dir;
  bool print_json = false;
  app.add_option("--shared", shared, "the shared folder holding data/vpr and data/vslam");
  app.add_option("--out", out_dir, "folder for vpr_results.json and vpr_results.md")->required();
  app.add_flag("--json", print_json, "also print the JSON results on stdout");
  waymark::crossing::FeatureOptions features;
  bool quick = false;
  app.add_option("--work-width", features.work_width, "working resolution (every database)");
  app.add_option("--work-height", features.work_height, "working resolution (every database)");
  app.add_flag("--keep-aspect", features.keep_aspect, "fit images into the working size");
  app.add_flag("--root-sift", features.root_sift, "RootSIFT descriptors");
  app.add_option("--max-keypoints", features.max_keypoints, "keypoint budget (0 = all)");
  app.add_flag("--quick", quick,
               "only the three modes at their defaults, printed, no result files (feature "
               "experiments)");
  std::string acceptance_csv;
  int vocabulary_rows = 0;
  app.add_option("--dump-acceptance", acceptance_csv,
                 "write every retrieval candidate with its evidence to this CSV and stop");
  app.add_option("--vocabulary-rows", vocabulary_rows,
                 "with --dump-acceptance: dense descriptors per view the vocabularies learn from");
  CLI11_PARSE(app, argc, argv);

  features.global_descriptor = true;  // the retrieval mode's dense RootSIFT
  waymark::vpr::Evaluation eval(shared, features, quick);
  if (!eval.Load()) {
    std::cerr << "no data to evaluate under " << shared << "/data\n";
    return 1;
  }
  if (!acceptance_csv.empty()) {
    eval.AcceptanceDump(acceptance_csv, vocabulary_rows);
    return 0;
  }
  eval.RunAll();
  if (quick) return 0;
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  const nlohmann::json j = eval.ToJson();
  {
    std::ofstream out(out_dir + "/vpr_results.json");
    out << j.dump(2) << "\n";
    if (!out) {
      std::cerr << "cannot write " << out_dir << "/vpr_results.json\n";
      return 1;
    }
  }
  {
    std::ofstream out(out_dir + "/vpr_results.md");
    out << eval.ToMarkdown();
    if (!out) {
      std::cerr << "cannot write " << out_dir << "/vpr_results.md\n";
      return 1;
    }
  }
  if (print_json) std::cout << j.dump(2) << "\n";
  std::cerr << "wrote " << out_dir << "/vpr_results.json and vpr_results.md\n";
  return 0;
}
