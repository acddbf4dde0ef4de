#include "server/crossing/view_database.h"

#include <cstring>

#include "server/crossing/decision.h"

namespace waymark::crossing {

uint32_t ViewDatabase::AddView(int64_t view_id, int64_t crossing_id, double heading_deg,
                               const cv::Mat& descriptors, std::vector<cv::Point2f> points,
                               std::vector<float> hue_hist, bool defer_indexing) {
  const uint32_t slot = static_cast<uint32_t>(views_.size());
  const cv::Mat continuous = descriptors.isContinuous() ? descriptors : descriptors.clone();
  ViewEntry entry;
  entry.view_id = view_id;
  entry.crossing_id = crossing_id;
  entry.heading_deg = heading_deg;
  entry.span.count = static_cast<uint32_t>(continuous.rows);
  entry.span.first =
      index_.Add(continuous.ptr<uint8_t>(), entry.span.count, slot, defer_indexing);
  entry.points = CompactPoints(points);
  entry.hue_hist = std::move(hue_hist);
  spans_.push_back(entry.span);
  views_.push_back(std::move(entry));
  return slot;
}

ClusterProposal ViewDatabase::ProposeCluster(const cv::Mat& descriptors,
                                             const ClusterOptions& options) const {
  ClusterProposal proposal;
  if (clusters_.empty()) return proposal;
  const std::vector<int> per_center = centers_.CountMatches(descriptors, options.ratio);
  proposal.cluster = AssignCluster(per_center, options.threshold);
  for (int m : per_center) proposal.matches = std::max(proposal.matches, m);
  return proposal;
}

namespace {

// The paper's step for one view: it joins cluster `join`, or (join < 0) founds a new one with
// itself as centre. Returns whether it joined.
bool JoinOrFound(std::vector<ClusterEntry>* clusters, int join, uint32_t slot) {
  if (join >= 0) {
    (*clusters)[join].members.push_back(slot);
    return true;
  }
  ClusterEntry cluster;
  cluster.center = slot;
  cluster.members.push_back(slot);
  clusters->push_back(std::move(cluster));
  return false;
}

}  // namespace

int ViewDatabase::NewCluster(int64_t cluster_id, uint32_t center_slot) {
  ClusterEntry cluster;
  cluster.cluster_id = cluster_id;
  cluster.center = center_slot;
  cluster.members.push_back(center_slot);
  clusters_.push_back(std::move(cluster));
  const int index = static_cast<int>(clusters_.size()) - 1;
  views_[center_slot].cluster = index;
  centers_.Add(views_[center_slot].span);
  return index;
}

void ViewDatabase::AddToCluster(int cluster, uint32_t slot) {
  clusters_[cluster].members.push_back(slot);
  views_[slot].cluster = cluster;
}

std::vector<ClusterEntry> ViewDatabase::ComputeClusters(const ClusterOptions& options) const {
  std::vector<ClusterEntry> clusters;
  CenterMatcher centers(index_.store());  // centres so far
  for (uint32_t slot = 0; slot < views_.size(); ++slot) {
    const int join =
        clusters.empty()
            ? -1
            : AssignCluster(centers.CountMatches(Descriptors(slot), options.ratio),
                            options.threshold);
    if (!JoinOrFound(&clusters, join, slot)) centers.Add(views_[slot].span);
  }
  return clusters;
}

void ViewDatabase::SetClusters(std::vector<ClusterEntry> clusters) {
  clusters_ = std::move(clusters);
  for (ViewEntry& v : views_) v.cluster = -1;
  // Centres in cluster order, as NewCluster would have added them.
  centers_.Clear();
  for (size_t c = 0; c < clusters_.size(); ++c) {
    for (uint32_t slot : clusters_[c].members) views_[slot].cluster = static_cast<int>(c);
    centers_.Add(views_[clusters_[c].center].span);
  }
}

cv::Mat ViewDatabase::Descriptors(uint32_t slot) const {
  const ViewSpan span = views_[slot].span;
  cv::Mat out(static_cast<int>(span.count), kDescriptorSize, CV_8U);
  for (uint32_t i = 0; i < span.count; ++i) {
    std::memcpy(out.ptr<uint8_t>(static_cast<int>(i)), index_.store().Get(span.first + i),
                kDescriptorSize);
  }
  return out;
}

void ViewDatabase::SetVocabulary(VladVocabulary vocabulary) {
  vocabulary_ = std::move(vocabulary);
  global_.Reset(vocabulary_.empty() ? 0 : vocabulary_.words() * kDescriptorSize);
}

void ViewDatabase::EncodeGlobal(uint32_t slot, const cv::Mat& dense_descriptors) {
  if (vocabulary_.empty()) return;
  global_.Set(slot, QuantizeGlobal(vocabulary_.Encode(dense_descriptors)));
}

void ViewDatabase::TrainGlobal(const std::vector<cv::Mat>& dense_per_slot, int words,
                               int sample_rows) {
  std::vector<cv::Mat> samples;
  for (const cv::Mat& d : dense_per_slot) samples.push_back(EvenRows(d, sample_rows));
  SetVocabulary(VladVocabulary::TrainOnImages(samples, words));
  for (uint32_t slot = 0; slot < dense_per_slot.size(); ++slot) {
    EncodeGlobal(slot, dense_per_slot[slot]);
  }
}

size_t ViewDatabase::memory_bytes() const {
  size_t bytes = index_.store().descriptor_bytes() + index_.memory_bytes() +
                 centers_.memory_bytes() + global_.memory_bytes();
  for (const ViewEntry& v : views_) {
    bytes += sizeof(ViewEntry) + v.points.memory_bytes() +
             v.hue_hist.capacity() * sizeof(float) + v.global_sample.total() * v.global_sample.elemSize();
  }
  return bytes;
}

std::vector<ClusterEntry> QuadraticClusters(const ViewDatabase& db, const ClusterOptions& options) {
  std::vector<ClusterEntry> clusters;
  for (uint32_t slot = 0; slot < db.views().size(); ++slot) {
    const cv::Mat descriptors = db.Descriptors(slot);
    std::vector<int> per_center;
    for (const ClusterEntry& c : clusters) {
      per_center.push_back(static_cast<int>(
          MatchViewExact(descriptors, db.index().store(), db.spans()[c.center], options.ratio)
              .size()));
    }
    const int join = AssignCluster(per_center, options.threshold);
    JoinOrFound(&clusters, join, slot);
  }
  return clusters;
}

}  // namespace waymark::crossing
