#ifndef WAYMARK_SERVER_CROSSING_ENROLLMENT_H_
#define WAYMARK_SERVER_CROSSING_ENROLLMENT_H_

// Enrolling a view into an in-memory ViewDatabase with the paper's incremental clustering, for
// callers without storage (tests, evaluations, benchmarks). The crossing service does the same
// steps with a storage transaction between ProposeCluster and AddView.

#include <cstdint>

#include "server/crossing/features.h"
#include "server/crossing/view_database.h"

namespace waymark::crossing {

struct EnrolledView {
  uint32_t slot = 0;
  bool new_cluster = false;
};

// Adds the view and puts it in its cluster. New clusters get `cluster_id` = the view's slot + 1
// (callers without storage have no other ids).
EnrolledView EnrollView(ViewDatabase* db, int64_t view_id, int64_t crossing_id, double heading_deg,
                        const ImageFeatures& features, const ClusterOptions& clustering = {});

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_ENROLLMENT_H_
