// Crossing recognition on real images: the VPR-Bench corridor and the Gardens Point / SFU triplets
// in ../shared/data/vpr (read in place; the test skips when the folder is absent). Runs the
// corridor and triplet experiments of waymark-vpr-eval (bench/crossing/vpr_experiment.h) in the
// three modes and guards the measured accuracy and the rejection of unknown places.
//
// Floors sit a little below what was measured (waymark-vpr-eval, 2-core machine, OpenCV 4.6);
// the measured values are in the comments. The engine's descriptor index is approximate, so a
// change to it moves single queries: the margins allow a few.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench/crossing/vpr_datasets.h"
#include "bench/crossing/vpr_experiment.h"
#include "server/crossing/global_index.h"
#include "server/crossing/options.h"

namespace waymark::vpr {
namespace {

using crossing::RecognitionMode;
using crossing::RecognitionOptions;

RecognitionOptions Paper() {
  RecognitionOptions o;
  o.mode = RecognitionMode::kPaper;
  return o;
}

RecognitionOptions Verified() {
  RecognitionOptions o;
  o.mode = RecognitionMode::kVerified;
  return o;
}

// The verified mode's ranking alone: no rejection rule.
RecognitionOptions VerifiedWithoutRejection() {
  RecognitionOptions o = Verified();
  o.min_inliers = 0;
  o.min_inlier_share = 0;
  return o;
}

// Each TEST runs in its own process under ctest (gtest_discover_tests), so the expensive part,
// extracting the features of the 252 images, is done lazily, once per process, on two threads;
// the tests are few and each covers a whole mode.
class RealDataTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string vpr = std::string(WAYMARK_SHARED_DIR) + "/data/vpr";
    std::error_code ec;
    if (!std::filesystem::is_directory(vpr, ec)) {
      skip_reason_ = new std::string("the real-data folder " + vpr +
                                     " is absent (../shared/data/vpr): real-data tests skipped");
      return;
    }
    const DataPaths paths = DefaultDataPaths(WAYMARK_SHARED_DIR);
    absl::StatusOr<CorridorSet> corridor = LoadCorridor(paths.corridor);
    absl::StatusOr<TripletSet> triplets = LoadTriplets(paths.triplets);
    if (!corridor.ok() || !triplets.ok()) {
      skip_reason_ = new std::string(
          "../shared/data/vpr is incomplete: " +
          std::string(!corridor.ok() ? corridor.status().message() : triplets.status().message()));
      return;
    }
    protocols_ = new std::map<std::string, std::vector<Protocol>>{
        {"corridor", {CorridorAll(*corridor)}},
        {"triplets", TripletFolds(*triplets)},
        {"corridor_unknown", {CorridorPartial(*corridor)}},
        {"triplets_unknown", TripletUnknownFolds(*triplets)},
        {"corridor_vs_triplet_db", {CorridorQueriesVsTripletDb(*corridor, *triplets)}},
        {"triplets_vs_corridor_db", {TripletQueriesVsCorridorDb(*corridor, *triplets)}},
    };
  }

  static void TearDownTestSuite() {
    paper_.reset();
    retrieval_.reset();
    delete protocols_;
    delete skip_reason_;
    protocols_ = nullptr;
    skip_reason_ = nullptr;
  }

  void SetUp() override {
    if (skip_reason_ != nullptr) GTEST_SKIP() << *skip_reason_;
    ASSERT_NE(protocols_, nullptr);
  }

  // The images' features and every database enrolled from them, under one feature setting.
  struct Prepared {
    explicit Prepared(const crossing::FeatureOptions& features) : cache(features) {}
    FeatureCache cache;
    std::map<std::string, std::vector<PreparedProtocol>> sets;
  };

  // Extracts every image's features and enrolls every database, once per process and setting:
  // the paper's features, or the retrieval mode's (RootSIFT, aspect kept, dense descriptors and a
  // vocabulary per database).
  static Prepared* PrepareAll(bool retrieval_features) {
    std::unique_ptr<Prepared>& slot = retrieval_features ? retrieval_ : paper_;
    if (slot != nullptr) return slot.get();
    crossing::FeatureOptions features;
    if (retrieval_features) {
      features.root_sift = true;
      features.keep_aspect = true;
      features.global_descriptor = true;
    }
    auto prepared = std::make_unique<Prepared>(features);
    std::vector<std::string> images;
    for (const auto& [name, protocols] : *protocols_) {
      for (const Protocol& p : protocols) {
        const std::vector<std::string> paths = ImagePaths(p);
        images.insert(images.end(), paths.begin(), paths.end());
      }
    }
    const absl::Status s = prepared->cache.Prefetch(images, 2);
    EXPECT_TRUE(s.ok()) << s;
    if (!s.ok()) return nullptr;
    for (const auto& [name, protocols] : *protocols_) {
      for (const Protocol& p : protocols) {
        absl::StatusOr<PreparedProtocol> one = Prepare(p, &prepared->cache);
        EXPECT_TRUE(one.ok()) << one.status();
        if (!one.ok()) return nullptr;
        prepared->sets[name].push_back(*std::move(one));
      }
    }
    slot = std::move(prepared);
    return slot.get();
  }

  // The tally of experiment `set` under `options` (on the retrieval mode's features when
  // options.mode is retrieval).
  static Tally Run(const std::string& set, const RecognitionOptions& options) {
    Prepared* prepared = PrepareAll(options.mode == RecognitionMode::kRetrieval);
    if (prepared == nullptr) return Tally{};
    absl::StatusOr<std::vector<QueryOutcome>> outcomes =
        RunQueries(prepared->sets.at(set), options);
    EXPECT_TRUE(outcomes.ok()) << outcomes.status();
    return outcomes.ok() ? Summarize(*outcomes) : Tally{};
  }

  static std::string* skip_reason_;
  static std::map<std::string, std::vector<Protocol>>* protocols_;
  static std::unique_ptr<Prepared> paper_, retrieval_;
};

std::string* RealDataTest::skip_reason_ = nullptr;
std::map<std::string, std::vector<Protocol>>* RealDataTest::protocols_ = nullptr;
std::unique_ptr<RealDataTest::Prepared> RealDataTest::paper_;
std::unique_ptr<RealDataTest::Prepared> RealDataTest::retrieval_;

TEST_F(RealDataTest, ExperimentsHaveTheDocumentedShape) {
  const Protocol& corridor = protocols_->at("corridor").front();
  EXPECT_EQ(corridor.enroll.size(), 111u);
  EXPECT_EQ(corridor.queries.size(), 111u);
  ASSERT_EQ(protocols_->at("triplets").size(), 3u);  // folds
  for (const Protocol& fold : protocols_->at("triplets")) {
    EXPECT_EQ(fold.enroll.size(), 10u);
    EXPECT_EQ(fold.queries.size(), 20u);
  }
  // Refs 0-54 enrolled; queries 0-50 have their ground truth in 0-52, queries 62-110 in 60-110.
  const Protocol& partial = protocols_->at("corridor_unknown").front();
  EXPECT_EQ(partial.enroll.size(), 55u);
  int known = 0, unknown = 0;
  for (const Query& q : partial.queries) (q.accepted.empty() ? unknown : known)++;
  EXPECT_EQ(known, 51);
  EXPECT_EQ(unknown, 49);
  // p0-p4 enrolled with one image each: 10 known and 15 unknown queries per fold.
  for (const Protocol& fold : protocols_->at("triplets_unknown")) {
    EXPECT_EQ(fold.enroll.size(), 5u);
    EXPECT_EQ(fold.queries.size(), 25u);
  }
}

TEST_F(RealDataTest, PaperMode) {
  const RecognitionOptions paper = Paper();
  {
    const Tally t = Run("corridor", paper);
    // Measured: 0/111 (R@1 0.0 %): with lambda = 0.32, the 160x120 fisheye images upsampled to
    // 320x240 (about 100 keypoints each) never give a cluster centre N0 = 5 matches across the
    // lateral offset. No decision is not a wrong decision: it must not answer wrongly either.
    EXPECT_LE(t.wrong, 3) << "corridor: measured 0 wrong answers";
  }
  {
    const Tally t = Run("triplets", paper);
    // Measured: 9/60 = 15.0 % (the 3 folds pooled = their mean), precision 100 %.
    EXPECT_GE(t.accuracy(), 0.10) << "triplets";
    EXPECT_LE(t.wrong, 3) << "triplets: measured 0 wrong answers";
  }
  // Measured: 0 false accepts on every unknown set (lambda = 0.32 rarely matches at all).
  for (const char* set : {"corridor_unknown", "triplets_unknown", "corridor_vs_triplet_db",
                          "triplets_vs_corridor_db"}) {
    EXPECT_LE(Run(set, paper).false_accept_rate(), 0.05) << set;
  }
}

TEST_F(RealDataTest, VerifiedMode) {
  const RecognitionOptions verified = Verified();
  {
    const Tally t = Run("corridor", verified);
    // Measured: 1-2/111 (R@1 0.9-1.8 %), precision 100 %: true matches have 7-20 inliers on these
    // images and the rejection rule (20) keeps almost all of them out.
    EXPECT_LE(t.wrong, 3) << "corridor: measured 0 wrong answers";
  }
  {
    const Tally t = Run("triplets", verified);
    // Measured: 20-21/60 = 33.3-35.0 %, precision 100 %.
    EXPECT_GE(t.accuracy(), 0.28) << "triplets";
    EXPECT_LE(t.wrong, 3) << "triplets: measured 0 wrong answers";
  }
  {
    // The ranking alone (matching, geometric verification, decision; every query answered).
    const Tally corridor = Run("corridor", VerifiedWithoutRejection());
    // Measured: 51-52/111 = 45.9-46.8 % (published R@1: HOG 47.8 %, NetVLAD 67.6 %).
    EXPECT_GE(corridor.accuracy(), 0.40) << "corridor without rejection";
    const Tally triplets = Run("triplets", VerifiedWithoutRejection());
    // Measured: 29-30/60 = 48.3-50.0 %.
    EXPECT_GE(triplets.accuracy(), 0.42) << "triplets without rejection";
  }
  // Places not in the database.
  const Tally corridor = Run("corridor_unknown", verified);
  const Tally triplets = Run("triplets_unknown", verified);
  const Tally cvt = Run("corridor_vs_triplet_db", verified);
  const Tally tvc = Run("triplets_vs_corridor_db", verified);
  // Measured false accepts: corridor 0/49; triplets 0/45 before and 2/45 (4.4 %) after the index
  // change of 829f47e: the Gardens Point night image p8/i2 reaches exactly 20 inliers (of 35-44
  // tentative matches) against unknown places in two folds, right at the rule's threshold;
  // corridor vs triplet db 0/111; triplets vs corridor db 0/30.
  EXPECT_EQ(corridor.unknown, 49);
  EXPECT_EQ(triplets.unknown, 45);
  EXPECT_LE(corridor.false_accept_rate(), 0.05) << "corridor_unknown";
  EXPECT_LE(triplets.false_accept_rate(), 0.07) << "triplets_unknown: at most 3 of 45";
  EXPECT_LE(cvt.false_accept_rate(), 0.03) << "corridor_vs_triplet_db";
  EXPECT_LE(tvc.false_accept_rate(), 0.07) << "triplets_vs_corridor_db: at most 2 of 30";
  const int unknown = corridor.unknown + triplets.unknown + cvt.unknown + tvc.unknown;
  const int accepted =
      corridor.false_accepts + triplets.false_accepts + cvt.false_accepts + tvc.false_accepts;
  // Measured: 0-2 of 235 (0-0.9 %).
  EXPECT_LE(static_cast<double>(accepted) / unknown, 0.03) << accepted << " of " << unknown;
  // The known half of the partial triplet databases: measured 10/30 = 33.3 %.
  EXPECT_GE(triplets.accuracy(), 0.25) << "triplets_unknown, known places";
}

// The retrieval mode (issue 18) at its defaults, on its own features: the global stage's shortlist
// and global path, the a-contrario NFA.
TEST_F(RealDataTest, RetrievalMode) {
  RecognitionOptions retrieval;
  retrieval.mode = RecognitionMode::kRetrieval;
  // Issue 34: the global path accepts under its chance model (global_chance.h, EFA < 10^-2).
  // Measured (waymark-vpr-heldout, same features): corridor 12/111 = 10.8 %, triplets 21/60 =
  // 35.0 %; the legacy lift rule (0.16): 62.2 % and 45.0 %, but 15.6 % false accepts on the
  // rotation set's held-out places.
  const Tally corridor_known = Run("corridor", retrieval);
  EXPECT_GE(corridor_known.accuracy(), 0.08) << "corridor";
  const Tally triplets_known = Run("triplets", retrieval);
  EXPECT_GE(triplets_known.accuracy(), 0.30) << "triplets";
  // Places not in the database.
  const Tally corridor = Run("corridor_unknown", retrieval);
  const Tally triplets = Run("triplets_unknown", retrieval);
  const Tally cvt = Run("corridor_vs_triplet_db", retrieval);
  const Tally tvc = Run("triplets_vs_corridor_db", retrieval);
  EXPECT_LE(corridor.false_accepts, 1) << "corridor_unknown, of 49";
  EXPECT_LE(triplets.false_accepts, 1) << "triplets_unknown, of 45";
  EXPECT_LE(cvt.false_accepts, 3) << "corridor_vs_triplet_db, of 111";
  EXPECT_LE(tvc.false_accepts, 1) << "triplets_vs_corridor_db, of 30";
  const int unknown = corridor.unknown + triplets.unknown + cvt.unknown + tvc.unknown;
  const int accepted =
      corridor.false_accepts + triplets.false_accepts + cvt.false_accepts + tvc.false_accepts;
  EXPECT_LE(static_cast<double>(accepted) / unknown, 0.03) << accepted << " of " << unknown;
  // The chance model's global path adds to what the NFA alone accepts on the corridor.
  RecognitionOptions nfa_only = retrieval;
  nfa_only.max_log10_global_efa = -10000;
  EXPECT_LE(Run("corridor", nfa_only).accuracy(), corridor_known.accuracy());
}

// The global stage's 8-bit exact scan against the float vectors it quantises, on real images:
// the corridor's 111 views and queries; the shortlist it feeds (top 24) must be the same views.
TEST_F(RealDataTest, GlobalScanShortlistsWhatTheFloatVectorsWould) {
  RecognitionOptions retrieval;
  retrieval.mode = RecognitionMode::kRetrieval;
  Prepared* prepared = PrepareAll(/*retrieval_features=*/true);
  ASSERT_NE(prepared, nullptr);
  const PreparedProtocol& corridor = prepared->sets.at("corridor").front();
  const crossing::ViewDatabase& db = *corridor.db;
  ASSERT_FALSE(db.global_index().empty());
  std::vector<cv::Mat> views;
  for (const Enrollment& e : corridor.protocol.enroll) {
    absl::StatusOr<const crossing::ImageFeatures*> f = prepared->cache.Get(e.path);
    ASSERT_TRUE(f.ok());
    views.push_back(db.vocabulary().Encode((*f)->dense));
  }
  const int k = retrieval.global_shortlist;
  double overlap = 0;
  int same_top1 = 0;
  for (const crossing::ImageFeatures* q : corridor.query_features) {
    const cv::Mat query = db.vocabulary().Encode(q->dense);
    std::vector<float> exact;
    for (const cv::Mat& v : views) exact.push_back(static_cast<float>(query.dot(v)));
    const auto top_exact = crossing::TopSimilar(exact, k);
    const auto top_scan =
        crossing::TopSimilar(db.global_index().Similarities(crossing::QuantizeGlobal(query)), k);
    same_top1 += top_exact[0].second == top_scan[0].second;
    for (const auto& [sim, slot] : top_scan) {
      overlap += std::any_of(top_exact.begin(), top_exact.end(),
                             [&](const auto& e) { return e.second == slot; });
    }
  }
  const double n = static_cast<double>(corridor.query_features.size());
  EXPECT_GE(overlap / (k * n), 0.97) << "shortlist recall of the 8-bit scan";
  EXPECT_GE(same_top1, n - 2) << "same most similar view";
}

}  // namespace
}  // namespace waymark::vpr
