#include "server/crossing/enrollment.h"

namespace waymark::crossing {

EnrolledView EnrollView(ViewDatabase* db, int64_t view_id, int64_t crossing_id, double heading_deg,
                        const ImageFeatures& features, const ClusterOptions& clustering) {
  const ClusterProposal proposal = db->ProposeCluster(features.descriptors, clustering);
  EnrolledView out;
  out.slot = db->AddView(view_id, crossing_id, heading_deg, features.descriptors,
                         KeypointPositions(features), features.hue_hist);
  if (proposal.cluster >= 0) {
    db->AddToCluster(proposal.cluster, out.slot);
  } else {
    db->NewCluster(static_cast<int64_t>(out.slot) + 1, out.slot);
    out.new_cluster = true;
  }
  return out;
}

}  // namespace waymark::crossing
