#ifndef WAYMARK_SERVER_CROSSING_RECOGNIZER_H_
#define WAYMARK_SERVER_CROSSING_RECOGNIZER_H_

// Recognition of one frame against a ViewDatabase: METHODS.md section 1 steps 3-9 (paper mode), or
// the verified mode that adds geometric verification and a rejection rule.

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/crossing/features.h"
#include "server/crossing/global_chance.h"
#include "server/crossing/options.h"
#include "server/crossing/view_database.h"

namespace waymark::crossing {

// One row of the paper's Table 1.
struct Candidate {
  uint32_t slot = 0;
  int matches = 0;         // M: ratio-test matches (verified mode: epipolar inliers)
  int tentative = 0;       // verified mode: matches before verification
  bool is_center = false;
  bool kept = false;       // among the top N2 that reached the histogram step
  double similarity = 0;   // S = 1 - Bhattacharyya distance (kept views only)
  double decision = 0;     // Des (kept views only)
  double log10_nfa = 0;    // retrieval mode: false alarms of the view as the answer (below)
  // Retrieval mode with a global descriptor: cosine similarity of the view's and the query's
  // (global_index.h), and how far it stands out of the query's similarities to all views
  // (robust z: (s - median) / (1.4826 MAD)).
  double global_similarity = 0;
  double global_z = 0;
};

// Which rule accepted an answer (issue 34: every answer says why).
enum class AcceptedBy {
  kRefused = 0,         // not recognized
  kDecision = 1,        // paper mode: the paper's decision (a centre reached N0)
  kInliers = 2,         // verified mode: the calibrated inlier rule
  kNfa = 3,             // retrieval mode: the epipolar match set's NFA < 10^max_log10_nfa
  kGlobal = 4,          // retrieval mode: the global chance model's EFA < 10^max_log10_global_efa
  kGlobalLift = 5,      // retrieval mode, legacy min_global_lift > 0 (off by default)
  kStreamEvidence = 6,  // StreamRecognize: the posterior over frames (set by the service)
};
// "refused", "decision", "inliers", "nfa", "global", "global_lift", "stream_evidence".
const char* AcceptedByName(AcceptedBy path);

struct Recognition {
  bool recognized = false;
  AcceptedBy accepted_by = AcceptedBy::kRefused;
  // Whether log10_nfa holds a computed value (retrieval mode, an answer or winner with a
  // geometric match set); false: log10_nfa is meaningless (0).
  bool nfa_computed = false;
  // Retrieval mode on a database with a global stage: whether it ran (false: no vocabulary yet,
  // or the query carried no dense descriptors), and its chance model (global_chance.h).
  bool global_stage = false;
  GlobalChance global;
  uint32_t best_slot = 0;  // valid when recognized
  double decision = 0;
  // Retrieval mode: log10 of the winner's expected number of false alarms (the lower, the
  // surer; < max_log10_nfa when recognized).
  double log10_nfa = 0;
  // Retrieval mode with a global descriptor: the highest global similarity minus the median over
  // all views, and whether the answer was accepted by the global path (kGlobal or the legacy
  // kGlobalLift) rather than on its NFA.
  double global_lift = 0;
  bool accepted_by_global = false;
  std::vector<Candidate> candidates;  // sorted by matches, descending
  int qualifying_clusters = 0;
  std::string reason;  // why not recognized
  RecognitionMode mode = RecognitionMode::kPaper;
  double matching_ms = 0;
  double retrieval_ms = 0;  // retrieval mode: global descriptor and scan over all views
  double verification_ms = 0;
  double histogram_ms = 0;  // comparing histograms (computing the query's is in extraction)
};

// INVALID_ARGUMENT for bad options, FAILED_PRECONDITION for an empty database. A frame where no
// cluster qualifies is a normal result with recognized = false.
absl::StatusOr<Recognition> Recognize(const ViewDatabase& database, const ImageFeatures& query,
                                      const RecognitionOptions& options);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_RECOGNIZER_H_
