#ifndef WAYMARK_SERVER_CROSSING_VIEW_DATABASE_H_
#define WAYMARK_SERVER_CROSSING_VIEW_DATABASE_H_

// The in-memory side of one crossing database: the views' features, the global descriptor index
// and the clusters. Not thread-safe: the owner serialises writers against readers (the crossing
// service holds a reader/writer lock per database).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "server/crossing/center_matcher.h"
#include "server/crossing/compact_points.h"
#include "server/crossing/descriptor_index.h"
#include "server/crossing/features.h"
#include "server/crossing/global_index.h"
#include "server/crossing/options.h"
#include "server/crossing/view_matching.h"
#include "server/crossing/vlad.h"

namespace waymark::crossing {

struct ViewEntry {
  int64_t view_id = 0;      // storage id; increasing = enrollment order
  int64_t crossing_id = 0;
  double heading_deg = 0;
  // Where in the crossing the view was taken ("north-kerb", "t=12.5s"; empty = not tagged).
  // Carried for the caller, never used by matching or clustering.
  std::string position;
  ViewSpan span;            // descriptors in the index's store
  CompactPoints points;     // keypoint positions at working resolution
  std::vector<float> hue_hist;
  int cluster = -1;         // index into clusters()
  // Retrieval mode: a few of the view's dense descriptors (EvenRows), what a retrained vocabulary
  // learns from without computing them again (empty when the database keeps no global stage).
  cv::Mat global_sample;
};

struct ClusterEntry {
  int64_t cluster_id = 0;  // storage id
  uint32_t center = 0;     // view slot
  std::vector<uint32_t> members;  // view slots, centre first
};

// Where the clustering puts a view.
struct ClusterProposal {
  int cluster = -1;  // existing cluster index, or -1 for a new cluster centred on the view
  int matches = 0;   // matches with that cluster's centre (the best centre's when -1)
};

class ViewDatabase {
 public:
  explicit ViewDatabase(const IndexOptions& index_options = {})
      : index_(index_options), centers_(index_.store()) {}
  ViewDatabase(const ViewDatabase&) = delete;
  ViewDatabase& operator=(const ViewDatabase&) = delete;

  // Adds a view; returns its slot. Its cluster is set separately (AddToCluster / NewCluster).
  // Loading a database = adding its views in enrollment order, which rebuilds the index exactly;
  // loaders pass `defer_indexing` and call FinishLoading() once at the end (much faster, same
  // forests).
  uint32_t AddView(int64_t view_id, int64_t crossing_id, double heading_deg,
                   const cv::Mat& descriptors, std::vector<cv::Point2f> points,
                   std::vector<float> hue_hist, bool defer_indexing = false);
  void FinishLoading() { index_.BuildPending(); }
  // Tags the view in `slot` with its capture position (ViewEntry::position).
  void SetPosition(uint32_t slot, std::string position) {
    views_[slot].position = std::move(position);
  }

  // The paper's clustering step for a view that is not yet a centre or member: matches against
  // every current centre (exact counts, through the CenterMatcher), the best one joins if it
  // reaches the threshold (the first of equal counts, as AssignCluster).
  ClusterProposal ProposeCluster(const cv::Mat& descriptors, const ClusterOptions& options) const;
  int NewCluster(int64_t cluster_id, uint32_t center_slot);
  void AddToCluster(int cluster, uint32_t slot);
  // Re-runs the clustering over all views in enrollment order. Returns the clusters as slot lists
  // (centre first); ids are left 0 for the caller to assign via SetClusters.
  std::vector<ClusterEntry> ComputeClusters(const ClusterOptions& options) const;
  void SetClusters(std::vector<ClusterEntry> clusters);

  // The retrieval mode's global descriptors (vlad.h, global_index.h): the vocabulary, and each
  // view's code under it. Setting a vocabulary drops every code (they belong to the old one).
  void SetVocabulary(VladVocabulary vocabulary);
  void SetGlobalCode(uint32_t slot, const GlobalCode& code) { global_.Set(slot, code); }
  GlobalCode global_code(uint32_t slot) const { return global_.Get(slot); }
  void SetGlobalSample(uint32_t slot, cv::Mat sample) {
    views_[slot].global_sample = std::move(sample);
  }
  // The view's code from its dense descriptors (dense_sift.h) under the current vocabulary.
  void EncodeGlobal(uint32_t slot, const cv::Mat& dense_descriptors);
  // Trains a vocabulary of `words` on `sample_rows` of each view's dense descriptors (one matrix
  // per slot, in slot order; EvenRows, as the service does) and encodes every view under it.
  void TrainGlobal(const std::vector<cv::Mat>& dense_per_slot, int words = kVladWords,
                   int sample_rows = kVocabularySampleRows);
  const VladVocabulary& vocabulary() const { return vocabulary_; }
  const GlobalIndex& global_index() const { return global_; }

  // The descriptors of a stored view as an N x 128 matrix (a copy).
  cv::Mat Descriptors(uint32_t slot) const;

  const std::vector<ViewEntry>& views() const { return views_; }
  const std::vector<ClusterEntry>& clusters() const { return clusters_; }
  const DescriptorIndex& index() const { return index_; }
  const std::vector<ViewSpan>& spans() const { return spans_; }
  size_t memory_bytes() const;  // descriptors + indexes + keypoints + histograms

 private:
  DescriptorIndex index_;
  // The cluster centres in cluster order (ids into index_'s store): the clustering matches new
  // views against centres only.
  CenterMatcher centers_;
  std::vector<ViewEntry> views_;
  std::vector<ClusterEntry> clusters_;
  std::vector<ViewSpan> spans_;  // mirror of views_[i].span, the shape the matchers take
  VladVocabulary vocabulary_;
  GlobalIndex global_;
};

// The paper's clustering verbatim, the reference ComputeClusters is tested against: every view in
// enrollment order matched by brute force (MatchViewExact) against every centre so far. Quadratic:
// for tests and benchmarks, not for the service.
std::vector<ClusterEntry> QuadraticClusters(const ViewDatabase& db, const ClusterOptions& options);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_VIEW_DATABASE_H_
