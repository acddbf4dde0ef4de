#include "server/crossing/recognizer.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <future>
#include <system_error>
#include <tuple>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/crossing/a_contrario.h"
#include "server/crossing/decision.h"
#include "server/crossing/geometric_verification.h"
#include "server/crossing/global_index.h"
#include "server/crossing/hue_histogram.h"
#include "server/common/stopwatch.h"

namespace waymark::crossing {
namespace {

// Match counts of the query against every view, through the index or (options.exact in the
// index options) brute force per view: the reference the benchmark compares against.
ViewMatches MatchQuery(const ViewDatabase& db, const cv::Mat& query, double ratio,
                       bool resolve_exactly) {
  if (!db.index().options().exact) {
    return MatchAllViews(query, db.index(), db.spans(), ratio, resolve_exactly);
  }
  ViewMatches all;
  for (uint32_t slot = 0; slot < db.views().size(); ++slot) {
    auto matches = MatchViewExact(query, db.index().store(), db.spans()[slot], ratio);
    if (!matches.empty()) all[slot] = std::move(matches);
  }
  return all;
}

int CountOf(const ViewMatches& matches, uint32_t slot) {
  auto it = matches.find(slot);
  return it == matches.end() ? 0 : static_cast<int>(it->second.size());
}

void SortByMatches(std::vector<Candidate>* list) {
  std::stable_sort(list->begin(), list->end(), [](const Candidate& a, const Candidate& b) {
    if (a.matches != b.matches) return a.matches > b.matches;
    return a.slot < b.slot;
  });
}

// Steps 6-9: keep the top N2, compare hue histograms, decide. Fills kept/similarity/decision and
// returns the index into `list` of the winner.
// `score` is the match score M of the decision (default: the match count).
int Decide(const ViewDatabase& db, const ImageFeatures& query, const RecognitionOptions& options,
           std::vector<Candidate>* list,
           const std::function<double(const Candidate&)>& score = [](const Candidate& c) {
             return static_cast<double>(c.matches);
           }) {
  const size_t kept = std::min<size_t>(list->size(), options.n2);
  std::vector<double> m;
  std::vector<double> s;
  for (size_t i = 0; i < kept; ++i) {
    Candidate& c = (*list)[i];
    c.kept = true;
    c.similarity = HueSimilarity(query.hue_hist, db.views()[c.slot].hue_hist);
    m.push_back(score(c));
    s.push_back(c.similarity);
  }
  const std::vector<double> des = DecisionValues(m, s, options.alpha, options.beta);
  for (size_t i = 0; i < kept; ++i) (*list)[i].decision = des[i];
  return ArgMax(des);
}

void RecognizePaper(const ViewDatabase& db, const ImageFeatures& query,
                    const RecognitionOptions& options, Recognition* out) {
  auto start = Clock::now();
  const ViewMatches matches = MatchQuery(db, query.descriptors, options.ratio, true);
  // Steps 3-5: qualifying centres, then members of their clusters with at least N1 matches.
  std::vector<Candidate> list;
  int best_center_matches = 0;
  for (const ClusterEntry& cluster : db.clusters()) {
    const int m = CountOf(matches, cluster.center);
    best_center_matches = std::max(best_center_matches, m);
    if (m < options.n0) continue;
    ++out->qualifying_clusters;
    list.push_back(Candidate{cluster.center, m, 0, true});
    for (uint32_t member : cluster.members) {
      if (member == cluster.center) continue;
      const int mm = CountOf(matches, member);
      if (mm >= options.n1) list.push_back(Candidate{member, mm, 0, false});
    }
  }
  out->matching_ms = MsSince(start);
  if (list.empty()) {
    out->reason = absl::StrCat("no cluster centre reached N0 = ", options.n0,
                               " matches (best centre: ", best_center_matches, ")");
    return;
  }
  SortByMatches(&list);
  start = Clock::now();
  const int best = Decide(db, query, options, &list);
  out->histogram_ms = MsSince(start);
  out->recognized = true;
  out->accepted_by = AcceptedBy::kDecision;
  out->best_slot = list[best].slot;
  out->decision = list[best].decision;
  out->candidates = std::move(list);
}

// The verified and retrieval modes' shortlist: the views with most tentative matches (ratio
// `verified_ratio`, through the index over every view), most first.
std::vector<std::pair<int, uint32_t>> Shortlist(const ViewMatches& tentative, int size) {
  std::vector<std::pair<int, uint32_t>> ranked;
  for (const auto& [slot, m] : tentative) ranked.emplace_back(static_cast<int>(m.size()), slot);
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  if (static_cast<int>(ranked.size()) > size) ranked.resize(size);
  return ranked;
}

// The matched keypoint positions of the query (`q`) and of the view (`v`), pair by pair.
void MatchedPoints(const ImageFeatures& query, const ViewEntry& view,
                   const std::vector<DescriptorMatch>& pairs, std::vector<cv::Point2f>* q,
                   std::vector<cv::Point2f>* v) {
  q->clear();
  v->clear();
  for (const DescriptorMatch& p : pairs) {
    q->push_back(query.keypoints[p.query_index].pt);
    v->push_back(view.points[p.train_id - view.span.first]);
  }
}

// The verified and retrieval modes' first stage: tentative matches against every view and the
// shortlist of those with most (timed as matching).
struct Shortlisted {
  ViewMatches tentative;
  std::vector<std::pair<int, uint32_t>> ranked;
  VerificationOptions verification;  // for the shortlist's RANSAC
};
Shortlisted TentativeShortlist(const ViewDatabase& db, const ImageFeatures& query,
                               const RecognitionOptions& options, Recognition* out) {
  const auto start = Clock::now();
  Shortlisted s;
  s.tentative = MatchQuery(db, query.descriptors, options.verified_ratio, false);
  s.ranked = Shortlist(s.tentative, options.shortlist);
  s.verification.threshold_px = options.ransac_threshold_px;
  out->matching_ms = MsSince(start);
  return s;
}

bool IsCenter(const ViewDatabase& db, uint32_t slot) {
  const ViewEntry& view = db.views()[slot];
  return view.cluster >= 0 && db.clusters()[view.cluster].center == slot;
}

void RecognizeVerified(const ViewDatabase& db, const ImageFeatures& query,
                       const RecognitionOptions& options, Recognition* out) {
  const Shortlisted shortlisted = TentativeShortlist(db, query, options, out);
  const auto& [tentative, ranked, verification] = shortlisted;
  auto start = Clock::now();
  std::vector<Candidate> list;
  std::vector<cv::Point2f> q, v;
  for (const auto& [count, slot] : ranked) {
    // Inliers are a subset of the tentative matches: a view with fewer tentative matches than the
    // rejection rule's minimum could never be accepted, so it is not worth a RANSAC.
    if (count < std::max(8, options.min_inliers)) continue;
    MatchedPoints(query, db.views()[slot], tentative.at(slot), &q, &v);
    const int inliers = CountEpipolarInliers(q, v, verification);
    if (inliers == 0) continue;
    list.push_back(Candidate{slot, inliers, count, IsCenter(db, slot)});
  }
  out->verification_ms = MsSince(start);
  if (list.empty()) {
    out->reason = "no view has geometrically consistent matches";
    return;
  }
  SortByMatches(&list);
  start = Clock::now();
  const int best = Decide(db, query, options, &list);
  out->histogram_ms = MsSince(start);
  const Candidate& winner = list[best];
  out->decision = winner.decision;
  const double share = winner.tentative > 0 ? winner.matches / double(winner.tentative) : 0;
  if (winner.matches < options.min_inliers || share < options.min_inlier_share) {
    out->reason = absl::StrCat("best view has ", winner.matches, " inliers (", winner.tentative,
                               " tentative): below the rejection rule (", options.min_inliers,
                               " inliers, share ", options.min_inlier_share, ")");
  } else {
    out->recognized = true;
    out->accepted_by = AcceptedBy::kInliers;
    out->best_slot = winner.slot;
  }
  out->candidates = std::move(list);
}

// The retrieval mode's global stage: how much each view's global similarity stands out of the
// query's similarities to all views. The bulk of a database is unrelated to any one query, so
// the median and the MAD of the similarities estimate the chance model of a similarity.
struct GlobalStage {
  std::vector<float> similarity;  // per slot; empty without a vocabulary or dense descriptors
  double median = 0;
  double spread = 0;  // 1.4826 x MAD, floored
  uint32_t top_slot = 0;  // the most similar view
  double lift = 0;        // how far it stands above the median

  bool active() const { return !similarity.empty(); }
  double Z(uint32_t slot) const { return (similarity[slot] - median) / spread; }
  // log10 of the chance that an unrelated view is as similar (the Gaussian tail beyond z).
  double Log10Tail(uint32_t slot) const {
    const double tail = 0.5 * std::erfc(Z(slot) / std::sqrt(2.0));
    return std::log10(std::max(tail, 1e-300));
  }
};

double Median(std::vector<float> values) {
  if (values.empty()) return 0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  return values[mid];
}

GlobalStage ScoreGlobally(const ViewDatabase& db, const ImageFeatures& query) {
  GlobalStage g;
  if (db.global_index().empty() || query.dense.empty()) return g;
  g.similarity = db.global_index().Similarities(QuantizeGlobal(db.vocabulary().Encode(query.dense)));
  g.median = Median(g.similarity);
  g.top_slot = static_cast<uint32_t>(
      std::max_element(g.similarity.begin(), g.similarity.end()) - g.similarity.begin());
  g.lift = g.similarity[g.top_slot] - g.median;
  std::vector<float> deviation;
  for (float s : g.similarity) deviation.push_back(std::abs(s - static_cast<float>(g.median)));
  // A floor keeps a database of near-identical views from dividing by almost nothing.
  g.spread = std::max(1.4826 * Median(deviation), 1e-3);
  return g;
}

// The shortlist's views by tentative count, then the global stage's most similar views that
// are not in it yet (their tentative count, 0 when they have no match).
void AddGlobalShortlist(const GlobalStage& g, const ViewMatches& tentative, int size,
                        std::vector<std::pair<int, uint32_t>>* ranked) {
  if (!g.active()) return;
  for (const auto& [similarity, slot] : TopSimilar(g.similarity, size)) {
    const bool listed = std::any_of(ranked->begin(), ranked->end(),
                                    [slot = slot](const auto& r) { return r.second == slot; });
    if (!listed) ranked->emplace_back(CountOf(tentative, slot), slot);
  }
}

// How far chance explains a view's tentative matches (a_contrario.h): the epipolar inliers of
// its fundamental matrix and log10 of their NFA per test, a probability (at most 0). Zero and
// zero when no matrix fits or nothing is an inlier.
struct GeometricEvidence {
  int inliers = 0;
  double log10_probability = 0;
};
GeometricEvidence JudgeMatchSet(const ImageFeatures& query, const ViewEntry& view,
                                const std::vector<DescriptorMatch>& pairs,
                                const VerificationOptions& verification, double tests,
                                std::vector<cv::Point2f>* q, std::vector<cv::Point2f>* v) {
  MatchedPoints(query, view, pairs, q, v);
  const std::optional<cv::Matx33d> f = EstimateFundamental(*q, *v, verification);
  if (!f) return {};
  // The smaller support of the two images is the more conservative random-point model.
  const cv::Size image(std::max(1, query.width), std::max(1, query.height));
  const cv::Size qs = MatchSupport(*q, image);
  const cv::Size vs = MatchSupport(*v, image);
  const EpipolarEvidence evidence =
      AContrarioEvidence(EpipolarResiduals(*f, *q, *v), qs.area() < vs.area() ? qs : vs, tests);
  if (evidence.inliers == 0) return {};
  return {evidence.inliers, std::min(0.0, evidence.log10_nfa - std::log10(tests))};
}

// What the global path saw, appended to a refusal's reason ("" without a global stage).
std::string GlobalRefusal(const GlobalStage& global, const GlobalChance& chance,
                          const RecognitionOptions& options) {
  if (!global.active()) return "";
  if (options.min_global_lift > 0) {
    return absl::StrFormat(
        "; the most similar view stands %.3f above the median global similarity (%.3f needed)",
        global.lift, options.min_global_lift);
  }
  if (!chance.computed) {
    return absl::StrFormat(
        "; global path: no chance model (%d views of other places, %d needed)",
        chance.background_views, GlobalChanceOptions().min_background_views);
  }
  return absl::StrFormat(
      "; global path: most similar view %.3f, 10^%.1f false alarms expected by chance, the "
      "limit is 10^%.1f%s",
      chance.best_similarity, chance.log10_efa, options.max_log10_global_efa,
      chance.log10_efa < 0 ? " (a weak frame: evidence over a stream may take it)" : "");
}

// Retrieval mode: the verified mode's shortlist joined by the views most similar globally; each
// view judged by its number of false alarms as the answer, the most meaningful first; the
// paper's hue and decision steps rank the top N2 (with -log10 NFA as the match score), and the
// winner is accepted when it is meaningful.
//
// A view's NFA is that of its epipolar match set over the shortlist (a_contrario.h). With
// global_evidence it also multiplies the chance that an unrelated view is as similar globally
// (GlobalStage), over the database's views as tests: N x P(global) x P(geometric).
void RecognizeRetrieval(const ViewDatabase& db, const ImageFeatures& query,
                        const RecognitionOptions& options, Recognition* out) {
  // The global scores (VLAD encoding and the scan of every view's code, read-only like the
  // tentative matching, under the same reader lock of the caller) on a thread of their own while
  // this one matches the descriptors: at 12,000 views the two take about as long, and a query
  // waited for both in turn (issue 34). On a busy server the two threads just share the cores.
  // (std::async: its future waits for the thread whichever way this function returns.)
  const auto score = [&db, &query] {
    const auto global_start = Clock::now();
    GlobalStage g = ScoreGlobally(db, query);
    return std::make_pair(std::move(g), MsSince(global_start));
  };
  std::future<std::pair<GlobalStage, double>> scored;
  if (!db.global_index().empty() && !query.dense.empty()) {
    try {
      scored = std::async(std::launch::async, score);
    } catch (const std::system_error&) {
      // No thread to be had: scored below, after the matching.
    }
  }
  Shortlisted shortlisted = TentativeShortlist(db, query, options, out);
  auto start = Clock::now();
  GlobalStage global;
  double global_ms = 0;
  std::tie(global, global_ms) = scored.valid() ? scored.get() : score();
  AddGlobalShortlist(global, shortlisted.tentative, options.global_shortlist, &shortlisted.ranked);
  // The global stage's own time, though it overlapped the matching.
  out->retrieval_ms = global_ms + MsSince(start);
  // References, not a structured binding: the lambda below captures them, which C++17 allows
  // for variables only (GCC also takes bindings, clang does not).
  const ViewMatches& tentative = shortlisted.tentative;
  const auto& ranked = shortlisted.ranked;
  const auto& verification = shortlisted.verification;
  start = Clock::now();
  // The match sets are judged over the shortlist's views as tests; with global_evidence every
  // view of the database is a candidate answer.
  const double shortlist_tests = std::max<double>(1.0, static_cast<double>(ranked.size()));
  const bool global_evidence = global.active() && options.global_evidence;
  const double log10_tests =
      global_evidence ? std::log10(static_cast<double>(db.views().size())) : 0.0;
  // Each view's RANSAC and NFA on OpenCV's worker threads (independent, and each seeds its own
  // RANSAC, so the answer does not depend on the threads); a busy server runs them inline.
  std::vector<GeometricEvidence> judged(ranked.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(ranked.size())), [&](const cv::Range& range) {
    std::vector<cv::Point2f> q, v;
    for (int i = range.start; i < range.end; ++i) {
      const auto& [count, slot] = ranked[i];
      if (count < 8) continue;
      judged[i] = JudgeMatchSet(query, db.views()[slot], tentative.at(slot), verification,
                                shortlist_tests, &q, &v);
    }
  });
  std::vector<Candidate> list;
  for (size_t i = 0; i < ranked.size(); ++i) {
    const auto& [count, slot] = ranked[i];
    const GeometricEvidence& geometric = judged[i];
    Candidate c{slot, geometric.inliers, count, IsCenter(db, slot)};
    if (global.active()) {
      c.global_similarity = global.similarity[slot];
      c.global_z = global.Z(slot);
    }
    if (global_evidence) {
      c.log10_nfa = log10_tests + global.Log10Tail(slot) + geometric.log10_probability;
    } else {
      if (c.matches == 0) continue;
      c.log10_nfa = std::log10(shortlist_tests) + geometric.log10_probability;
    }
    list.push_back(c);
  }
  out->verification_ms = MsSince(start);
  // The global path's chance model (global_chance.h), over the places of the views.
  GlobalChance chance;
  if (global.active()) {
    out->global_stage = true;
    out->global_lift = global.lift;
    std::vector<int64_t> place_of_slot(db.views().size());
    for (size_t i = 0; i < place_of_slot.size(); ++i) place_of_slot[i] = db.views()[i].crossing_id;
    chance = EstimateGlobalChance(global.similarity, place_of_slot);
    out->global = chance;
  }
  // Legacy lift rule (off by default): checked before the NFA, as in issue 18.
  const bool lift_accepts = global.active() && options.min_global_lift > 0 &&
                            global.lift >= options.min_global_lift;
  // The chance model's rule: only where the geometry did not accept (below).
  const bool chance_accepts = global.active() && options.min_global_lift <= 0 && chance.computed &&
                              chance.log10_efa < options.max_log10_global_efa;
  // The global path's answer: the most similar view, with its own NFA when it has a match set.
  auto accept_global = [&](AcceptedBy path, const std::vector<Candidate>& candidates) {
    out->recognized = true;
    out->accepted_by = path;
    out->accepted_by_global = true;
    out->best_slot = global.top_slot;
    out->nfa_computed = false;
    out->log10_nfa = 0;
    for (const Candidate& c : candidates) {
      if (c.slot == out->best_slot) {
        out->log10_nfa = c.log10_nfa;
        out->nfa_computed = true;
      }
    }
  };
  if (list.empty()) {
    if (lift_accepts) {
      accept_global(AcceptedBy::kGlobalLift, list);
    } else if (chance_accepts) {
      accept_global(AcceptedBy::kGlobal, list);
    } else {
      out->reason = "no view has geometrically consistent matches";
      out->reason += GlobalRefusal(global, chance, options);
    }
    return;
  }
  std::stable_sort(list.begin(), list.end(), [](const Candidate& a, const Candidate& b) {
    return a.log10_nfa < b.log10_nfa;
  });
  start = Clock::now();
  const int best = Decide(db, query, options, &list, [](const Candidate& c) {
    return std::max(0.0, -c.log10_nfa);
  });
  out->histogram_ms = MsSince(start);
  const Candidate winner = list[best];
  out->decision = winner.decision;
  out->log10_nfa = winner.log10_nfa;
  out->nfa_computed = true;
  out->candidates = std::move(list);
  if (lift_accepts) {
    accept_global(AcceptedBy::kGlobalLift, out->candidates);
  } else if (winner.log10_nfa < options.max_log10_nfa) {
    // Geometry is the main evidence: a meaningful match set is the answer whatever the global
    // stage prefers.
    out->recognized = true;
    out->accepted_by = AcceptedBy::kNfa;
    out->best_slot = winner.slot;
  } else if (chance_accepts) {
    accept_global(AcceptedBy::kGlobal, out->candidates);
  } else {
    out->reason = absl::StrFormat(
        "best view (%d inliers of %d tentative matches, global similarity %.3f) could be "
        "chance: 10^%.1f false alarms expected, the limit is 10^%.1f",
        winner.matches, winner.tentative, winner.global_similarity, winner.log10_nfa,
        options.max_log10_nfa);
    out->reason += GlobalRefusal(global, chance, options);
  }
}

}  // namespace

const char* AcceptedByName(AcceptedBy path) {
  switch (path) {
    case AcceptedBy::kRefused: return "refused";
    case AcceptedBy::kDecision: return "decision";
    case AcceptedBy::kInliers: return "inliers";
    case AcceptedBy::kNfa: return "nfa";
    case AcceptedBy::kGlobal: return "global";
    case AcceptedBy::kGlobalLift: return "global_lift";
    case AcceptedBy::kStreamEvidence: return "stream_evidence";
  }
  return "refused";
}

absl::StatusOr<Recognition> Recognize(const ViewDatabase& database, const ImageFeatures& query,
                                      const RecognitionOptions& options) {
  if (absl::Status s = ValidateRecognitionOptions(options); !s.ok()) return s;
  if (database.views().empty()) {
    return absl::FailedPreconditionError("the database has no views: enroll some first");
  }
  Recognition out;
  out.mode = options.mode;
  if (query.descriptors.rows == 0) {
    out.reason = "no SIFT keypoints in the image (no texture)";
    return out;
  }
  if (options.mode == RecognitionMode::kVerified) {
    RecognizeVerified(database, query, options, &out);
  } else if (options.mode == RecognitionMode::kRetrieval) {
    RecognizeRetrieval(database, query, options, &out);
  } else {
    RecognizePaper(database, query, options, &out);
  }
  return out;
}

}  // namespace waymark::crossing
