#include "storage/crossing_records.h"

#include <cmath>
#include <unordered_set>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "storage/sha256.h"

namespace waymark::storage {

absl::Status ValidateView(const ViewRecord& view) {
  if (view.keypoint_count < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("keypoint_count is negative (", view.keypoint_count, ")"));
  }
  const int64_t count = view.keypoint_count;
  if (static_cast<int64_t>(view.keypoints.size()) != count * kKeypointFloats) {
    return absl::InvalidArgumentError(absl::StrCat(
        "view has ", count, " keypoints but ", view.keypoints.size(), " keypoint floats; expected ",
        count * kKeypointFloats, " (", kKeypointFloats, " per keypoint)"));
  }
  if (static_cast<int64_t>(view.descriptors.size()) != count * kDescriptorBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("view has ", count, " keypoints but ", view.descriptors.size(),
                     " descriptor bytes; expected ", count * kDescriptorBytes, " (",
                     kDescriptorBytes, " per keypoint)"));
  }
  if (view.width < 0 || view.height < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("view size ", view.width, "x", view.height, " is negative"));
  }
  // SQLite stores NaN as NULL, which the NOT NULL column would reject with an opaque error.
  if (!std::isfinite(view.heading_deg)) {
    return absl::InvalidArgumentError("view heading_deg is not a finite number");
  }
  if (!view.content_sha256.empty() && view.content_sha256.size() != kSha256Bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("view content_sha256 has ", view.content_sha256.size(), " bytes; expected ",
                     kSha256Bytes, " (a SHA-256 digest) or none"));
  }
  return absl::OkStatus();
}

absl::Status ValidateReplacement(const ViewReplacement& replacement) {
  if (absl::Status s = ValidateView(replacement.view); !s.ok()) return s;
  if (replacement.join_cluster >= static_cast<int>(replacement.clusters.size())) {
    return absl::InvalidArgumentError(absl::StrCat("join_cluster ", replacement.join_cluster,
                                                   " is not one of the ",
                                                   replacement.clusters.size(), " clusters"));
  }
  return absl::OkStatus();
}

absl::Status CheckStoredBlobSize(int64_t actual, int64_t expected, int64_t view_id,
                                 const char* what) {
  if (actual != expected) {
    return absl::DataLossError(absl::StrCat("view ", view_id, ": stored ", what, " blob has ",
                                            actual, " bytes, expected ", expected));
  }
  return absl::OkStatus();
}

std::string ClusterName(const ClusterRecord& cluster, size_t index) {
  return absl::StrCat("cluster #", index, " (centre view ", cluster.center_view_id, ")");
}

absl::Status CheckClusterShape(const ClusterRecord& cluster, size_t index) {
  std::unordered_set<int64_t> seen;
  for (int64_t view_id : cluster.member_view_ids) {
    if (!seen.insert(view_id).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(ClusterName(cluster, index), " lists view ", view_id, " twice"));
    }
  }
  if (seen.count(cluster.center_view_id) == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(ClusterName(cluster, index), ": the centre is not among the members"));
  }
  return absl::OkStatus();
}

absl::Status NameTaken(absl::Status status, const std::string& what) {
  if (absl::IsAlreadyExists(status)) return absl::AlreadyExistsError(what + " already exists");
  return status;
}

absl::Status DuplicateImage(int64_t view_id, const std::string& content_sha256) {
  return absl::AlreadyExistsError(absl::StrCat("view ", view_id,
                                               " already holds this image (SHA-256 ",
                                               HexString(content_sha256), ")"));
}

absl::StatusOr<std::vector<ViewRecord>> CrossingStore::LoadViews(int64_t database_id) {
  std::vector<ViewRecord> views;
  absl::Status visited = ForEachView(database_id, [&views](ViewRecord&& view) {
    views.push_back(std::move(view));
    return absl::OkStatus();
  });
  if (!visited.ok()) return visited;
  return views;
}

absl::Status DatabaseNotFound(int64_t database_id) {
  return absl::NotFoundError(absl::StrCat("database ", database_id, " not found"));
}

absl::Status ViewNotFound(int64_t view_id) {
  return absl::NotFoundError(absl::StrCat("view ", view_id, " not found"));
}

}  // namespace waymark::storage
