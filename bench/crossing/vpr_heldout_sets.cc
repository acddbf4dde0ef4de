#include "bench/crossing/vpr_heldout_sets.h"

#include <algorithm>
#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace waymark::vpr {
namespace {

constexpr int kHeadings = 12;
constexpr double kStepDeg = 30;

}  // namespace

std::vector<Protocol> CorridorHeldOut(const CorridorSet& set, int blocks, int margin) {
  std::vector<Protocol> folds;
  const int refs = static_cast<int>(set.refs.size());
  for (int b = 0; b < blocks; ++b) {
    const int lo = b * refs / blocks;
    const int hi = (b + 1) * refs / blocks - 1;
    Protocol p;
    p.name = absl::StrCat("corridor_heldout_", lo, "-", hi);
    for (int r = 0; r < refs; ++r) {
      if (r < lo || r > hi) p.enroll.push_back({set.refs[r], r, 0.0});
    }
    for (size_t q = 0; q < set.queries.size(); ++q) {
      const std::vector<int>& gt = set.ground_truth[q];
      if (gt.empty()) continue;
      const int g_lo = *std::min_element(gt.begin(), gt.end());
      const int g_hi = *std::max_element(gt.begin(), gt.end());
      Query query;
      query.path = set.queries[q];
      if (g_hi < lo || g_lo > hi) {
        query.accepted = std::vector<int64_t>(gt.begin(), gt.end());
      } else if (!(g_lo >= lo + margin && g_hi <= hi - margin)) {
        continue;  // at the block's edge: neither clearly known nor clearly unknown
      }
      p.queries.push_back(query);
    }
    folds.push_back(std::move(p));
  }
  return folds;
}

std::vector<Protocol> TripletHeldOut(const TripletSet& set, int held_out_places) {
  std::vector<Protocol> folds;
  const size_t slots = set.images.empty() ? 0 : set.images[0].size();
  for (size_t k = 0; k < slots; ++k) {
    for (int first = 0; first + held_out_places <= set.places(); first += held_out_places) {
      folds.push_back(TripletFoldWithUnknowns(
          set, k,
          [&](int place) { return place < first || place >= first + held_out_places; },
          absl::StrCat("triplets_heldout_fold", k, "_p", first, "-",
                       first + held_out_places - 1)));
    }
  }
  return folds;
}

std::vector<Protocol> SequenceHeldOut(const FrameSequence& seq, int stride, double min_distance_m) {
  std::vector<Protocol> folds;
  const size_t half = seq.frames.size() / 2;
  for (int fold = 0; fold < 2; ++fold) {
    const size_t begin = fold == 0 ? 0 : half;
    const size_t end = fold == 0 ? half : seq.frames.size();
    Protocol p;
    p.name = absl::StrCat(seq.name, "_heldout_every", stride, fold == 0 ? "_first" : "_second");
    std::vector<const PosedFrame*> enrolled;
    for (size_t i = begin; i < end; i += stride) {
      enrolled.push_back(&seq.frames[i]);
      p.enroll.push_back({seq.frames[i].path, seq.frames[i].index, 0.0});
    }
    for (size_t i = 0; i < seq.frames.size(); ++i) {
      if (i >= begin && i < end) continue;
      const PosedFrame& f = seq.frames[i];
      double nearest = std::numeric_limits<double>::infinity();
      for (const PosedFrame* e : enrolled) {
        nearest = std::min(nearest, cv::norm(e->position - f.position));
      }
      if (nearest < min_distance_m) continue;
      Query q;
      q.path = f.path;
      q.distance_m = nearest;
      p.queries.push_back(q);
    }
    folds.push_back(std::move(p));
  }
  return folds;
}

std::string RotationKey(const std::string& panorama, double heading_deg, double fov_deg) {
  return absl::StrFormat("rotation:%s:%.1f:%.0f", panorama, heading_deg, fov_deg);
}

namespace {

void EnrollPlace(const std::string& panorama, int64_t place, double fov, Protocol* p) {
  for (int k = 0; k < kHeadings; ++k) {
    p->enroll.push_back({RotationKey(panorama, k * kStepDeg, fov), place, k * kStepDeg});
  }
}

void QueryPlace(const std::string& panorama, int64_t place, const std::vector<double>& offsets,
                double fov, Protocol* p) {
  for (double offset : offsets) {
    for (int k = 0; k < kHeadings; ++k) {
      Query q;
      q.path = RotationKey(panorama, k * kStepDeg + offset, fov);
      if (place >= 0) q.accepted = {place};
      p->queries.push_back(q);
    }
  }
}

}  // namespace

Protocol RotationKnown(const std::vector<std::string>& panoramas,
                       const std::vector<double>& offsets, double fov_deg) {
  Protocol p;
  p.name = "rotation";
  for (size_t i = 0; i < panoramas.size(); ++i) EnrollPlace(panoramas[i], i + 1, fov_deg, &p);
  for (size_t i = 0; i < panoramas.size(); ++i) {
    QueryPlace(panoramas[i], i + 1, offsets, fov_deg, &p);
  }
  return p;
}

std::vector<Protocol> RotationHeldOut(const std::vector<std::string>& panoramas,
                                      const std::vector<double>& offsets, double fov_deg) {
  std::vector<Protocol> folds;
  const size_t n = panoramas.size();
  if (n < 3) return folds;
  for (size_t f = 0; f < n; f += 2) {
    const size_t a = f, b = (f + 1) % n;
    Protocol p;
    p.name = absl::StrCat("rotation_heldout_", a, "_", b);
    for (size_t i = 0; i < n; ++i) {
      if (i != a && i != b) EnrollPlace(panoramas[i], i + 1, fov_deg, &p);
    }
    QueryPlace(panoramas[a], -1, offsets, fov_deg, &p);
    QueryPlace(panoramas[b], -1, offsets, fov_deg, &p);
    folds.push_back(std::move(p));
  }
  return folds;
}

}  // namespace waymark::vpr
