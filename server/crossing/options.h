#ifndef WAYMARK_SERVER_CROSSING_OPTIONS_H_
#define WAYMARK_SERVER_CROSSING_OPTIONS_H_

// Parameters of crossing recognition. Defaults are the paper's values (METHODS.md section 1)
// where the paper gives one; every other default is ours and says so.

#include "absl/status/status.h"

namespace waymark::crossing {

enum class RecognitionMode {
  // METHODS.md section 1 exactly: ratio test, cluster centres, members, hue histogram, decision.
  kPaper = 1,
  // Beyond the paper: looser ratio, shortlist from the global index, geometric verification
  // (RANSAC fundamental matrix, inliers are the match count) and a calibrated rejection rule.
  kVerified = 2,
};

struct FeatureOptions {
  // Working resolution: every image is resized to this before extraction (the paper's 320x240).
  int work_width = 320;
  int work_height = 240;
  // Hue histogram bins. The paper gives no k; 36 bins = 10 degrees of hue each (ours).
  int hue_bins = 36;
  // Keep at most this many SIFT keypoints (strongest first); 0 = no limit (ours; the paper has none).
  int max_keypoints = 0;
};

struct ClusterOptions {
  // A view joins the best-matching cluster centre when it has at least this many matches (paper: 5).
  int threshold = 5;
  // Ratio used when counting matches for clustering (paper: lambda = 0.32).
  double ratio = 0.32;
};

struct RecognitionOptions {
  RecognitionMode mode = RecognitionMode::kPaper;
  double ratio = 0.32;  // lambda: accept the nearest neighbour if dis_a < lambda * dis_b
  int n0 = 5;           // a cluster centre qualifies with at least N0 matches
  int n1 = 10;          // a member of a qualifying cluster enters the list with at least N1
  int n2 = 3;           // views kept for the hue-histogram step
  double alpha = 0.5;   // decision weight of matches
  double beta = 0.5;    // decision weight of hue similarity

  // Verified mode (ours). The rejection rule was calibrated with waymark-vpr-eval
  // (bench/vpr_eval.cc) on ../shared/data: the VPR-Bench corridor, the Gardens Point / SFU
  // triplets, KITTI 06 frames 0-50 and Bonn crowd frames 270-409. min_inliers 20 is the smallest
  // value of {8, 10, 12, 15, 20, 25, 30} that keeps false accepts <= 5 % on every set of places not
  // in the database (15 lets 13 % of the unknown triplet queries through, 25 costs 5 points of
  // triplet accuracy); min_inlier_share made no difference between 0.1 and 0.2 there.
  double verified_ratio = 0.8;      // Lowe's usual ratio before geometric verification
  int min_inliers = 20;             // rejection rule: the winning view needs this many inliers...
  double min_inlier_share = 0.2;    // ...and this share of its tentative matches
  double ransac_threshold_px = 3.0; // max epipolar distance at working resolution
  int shortlist = 24;               // views verified per query, ranked by index votes
};

// Search parameters of the global descriptor index (ours; see descriptor_index.h).
struct IndexOptions {
  int trees = 4;          // randomized k-d trees
  int leaf_size = 8;      // descriptors per leaf
  int checks = 64;        // leaves visited per query descriptor (over all trees)
  int knn = 16;           // neighbours fetched per query descriptor
  // Count matches exactly (brute force per view) instead of through the index: the reference the
  // benchmark compares the index against.
  bool exact = false;
};

absl::Status ValidateFeatureOptions(const FeatureOptions& options);
absl::Status ValidateClusterOptions(const ClusterOptions& options);
absl::Status ValidateRecognitionOptions(const RecognitionOptions& options);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_OPTIONS_H_
