#include "server/service/crossing/crossing_database.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"

namespace waymark::service {

absl::Status ValidateCrossingName(const std::string& name) {
  if (name.empty() || name.size() > 128) {
    return absl::InvalidArgumentError(
        absl::StrCat("crossing name ", QuoteClientText(name), " must be 1-128 characters long"));
  }
  for (char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == '/') {
      return absl::InvalidArgumentError(
          absl::StrCat("crossing name ", QuoteClientText(name),
                       " may not contain '/' or control characters"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateHeading(double heading_deg) {
  if (!std::isfinite(heading_deg) || heading_deg < 0 || heading_deg >= 360) {
    return absl::InvalidArgumentError(absl::StrCat("heading_deg = ", heading_deg,
                                                   " is outside [0, 360): give the view's compass "
                                                   "heading in degrees, clockwise"));
  }
  return absl::OkStatus();
}

absl::Status ValidatePosition(const std::string& position) {
  if (position.size() > 64) {
    // Quoted by characters, never cut inside one (a cut UTF-8 character made the whole
    // BulkEnroll answer unreadable to strict clients: issue 35).
    return absl::InvalidArgumentError(absl::StrCat("position ", QuoteClientText(position), " is ",
                                                   position.size(),
                                                   " bytes long (UTF-8); at most 64"));
  }
  for (char c : position) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      return absl::InvalidArgumentError(
          absl::StrCat("position ", QuoteClientText(position),
                       " may not contain control characters"));
    }
  }
  return absl::OkStatus();
}

bool SameHeading(double a_deg, double b_deg) {
  if (std::isnan(a_deg) || std::isnan(b_deg)) return std::isnan(a_deg) && std::isnan(b_deg);
  return std::abs(a_deg - b_deg) < 1e-6;
}

double RequestedHeading(const v1::EnrollViewRequest& request) {
  return request.heading_unknown() ? kNoHeading : request.heading_deg();
}

void ViewContents::Add(int64_t view_id, const std::string& sha256) {
  if (sha256.empty()) return;
  view_by_hash_[sha256] = view_id;
  hash_by_view_[view_id] = sha256;
}

void ViewContents::Remove(int64_t view_id) {
  auto it = hash_by_view_.find(view_id);
  if (it == hash_by_view_.end()) return;
  view_by_hash_.erase(it->second);
  hash_by_view_.erase(it);
}

std::optional<int64_t> ViewContents::Find(const std::string& sha256) const {
  auto it = view_by_hash_.find(sha256);
  if (it == view_by_hash_.end()) return std::nullopt;
  return it->second;
}

absl::Status ResidentDatabase::CheckAlive() const {
  if (deleted) {
    return absl::NotFoundError(absl::StrCat("database \"", record.name, "\" was deleted"));
  }
  return absl::OkStatus();
}

void ResidentDatabase::TakeContentsOf(ResidentDatabase&& fresh) {
  record = std::move(fresh.record);
  params = std::move(fresh.params);
  options = fresh.options;
  views = std::move(fresh.views);
  crossings = std::move(fresh.crossings);
  crossing_ids = std::move(fresh.crossing_ids);
  views_per_crossing = std::move(fresh.views_per_crossing);
  contents = std::move(fresh.contents);
  keypoints = fresh.keypoints;
  const bool scheduled = global.scheduled;  // the worker's bookkeeping, not the database's
  global = std::move(fresh.global);
  global.scheduled = scheduled;
}

void ResidentDatabase::AddCrossingRecord(const storage::CrossingRecord& c) {
  crossings[c.id] = c;
  crossing_ids[c.name] = c.id;
}

std::string ResidentDatabase::CrossingName(int64_t crossing_id) const {
  auto it = crossings.find(crossing_id);
  return it == crossings.end() ? std::string() : it->second.name;
}

const crossing::ViewEntry* ResidentDatabase::FindView(int64_t view_id) const {
  const std::vector<crossing::ViewEntry>& all = views->views();
  auto it =
      std::lower_bound(all.begin(), all.end(), view_id,
                       [](const crossing::ViewEntry& v, int64_t id) { return v.view_id < id; });
  return it != all.end() && it->view_id == view_id ? &*it : nullptr;
}

void ResidentDatabase::InstallClusters(const std::vector<storage::ClusterRecord>& records,
                                       crossing::ViewDatabase* target) {
  std::unordered_map<int64_t, uint32_t> slot_of;
  for (uint32_t s = 0; s < target->views().size(); ++s) slot_of[target->views()[s].view_id] = s;
  std::vector<crossing::ClusterEntry> clusters;
  for (const auto& r : records) {
    crossing::ClusterEntry c;
    c.cluster_id = r.id;
    c.center = slot_of.at(r.center_view_id);
    c.members.push_back(c.center);
    for (int64_t v : r.member_view_ids) {
      if (v != r.center_view_id) c.members.push_back(slot_of.at(v));
    }
    clusters.push_back(std::move(c));
  }
  target->SetClusters(std::move(clusters));
}

std::vector<storage::ClusterRecord> ResidentDatabase::ToRecords(
    const crossing::ViewDatabase& source, const std::vector<crossing::ClusterEntry>& clusters) {
  std::vector<storage::ClusterRecord> records;
  for (const auto& c : clusters) {
    storage::ClusterRecord r;
    r.center_view_id = source.views()[c.center].view_id;
    for (uint32_t s : c.members) r.member_view_ids.push_back(source.views()[s].view_id);
    records.push_back(std::move(r));
  }
  return records;
}

RemainingViews CopyViewsExcept(const crossing::ViewDatabase& source,
                               const std::function<bool(const crossing::ViewEntry&)>& drop,
                               const crossing::IndexOptions& index_options) {
  RemainingViews remaining;
  remaining.views = std::make_unique<crossing::ViewDatabase>(index_options);
  remaining.views->SetVocabulary(source.vocabulary());
  for (uint32_t s = 0; s < source.views().size(); ++s) {
    const crossing::ViewEntry& v = source.views()[s];
    if (drop(v)) {
      remaining.dropped_view_ids.push_back(v.view_id);
      remaining.dropped_per_crossing[v.crossing_id]++;
      continue;
    }
    const uint32_t slot =
        remaining.views->AddView(v.view_id, v.crossing_id, v.heading_deg, source.Descriptors(s),
                                 v.points.ToVector(), v.hue_hist,
                                 /*defer_indexing=*/true);
    remaining.views->SetPosition(slot, v.position);
    remaining.views->SetGlobalSample(slot, v.global_sample);
    remaining.views->SetGlobalCode(slot, source.global_code(s));
    remaining.keypoints += v.span.count;
  }
  remaining.views->FinishLoading();
  return remaining;
}

storage::ViewRecord ToViewRecord(int64_t crossing_id, double heading_deg,
                                 const crossing::ImageFeatures& features) {
  storage::ViewRecord r;
  r.crossing_id = crossing_id;
  // Storage keeps a finite heading and says whether it is known (schema v13).
  r.heading_known = !std::isnan(heading_deg);
  r.heading_deg = r.heading_known ? heading_deg : 0;
  r.width = features.width;
  r.height = features.height;
  r.keypoint_count = static_cast<int32_t>(features.keypoints.size());
  r.keypoints.reserve(features.keypoints.size() * storage::kKeypointFloats);
  for (const cv::KeyPoint& kp : features.keypoints) {
    r.keypoints.insert(r.keypoints.end(), {kp.pt.x, kp.pt.y, kp.size, kp.angle, kp.response,
                                           static_cast<float>(kp.octave)});
  }
  r.descriptors.assign(features.descriptors.datastart, features.descriptors.dataend);
  r.hue_hist = features.hue_hist;
  return r;
}

}  // namespace waymark::service
