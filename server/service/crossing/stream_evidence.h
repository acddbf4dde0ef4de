#ifndef WAYMARK_SERVER_SERVICE_CROSSING_STREAM_EVIDENCE_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_STREAM_EVIDENCE_H_

// StreamRecognize's evidence over frames (retrieval mode): one PlaceEvidenceFilter per stream,
// fed with each frame's candidates, and the answer rewritten to the belief's decision
// (crossing.proto, RecognizeResponse.evidence).

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "server/service/crossing/folder.h"
#include "waymark/v1/crossing.pb.h"
#include "server/crossing/options.h"
#include "server/crossing/place_evidence.h"

namespace waymark::service {

class StreamEvidence {
 public:
  // Integrates the frame's answer if `options` ask for evidence (retrieval mode, threshold > 0)
  // and rewrites it; otherwise leaves it as the frame's own answer. A change of threshold within
  // the stream starts the belief afresh.
  void Apply(const crossing::RecognitionOptions& options, v1::RecognizeResponse* response);

 private:
  std::optional<crossing::PlaceEvidenceFilter> filter_;
  double threshold_ = -1;
  std::map<int64_t, std::string> names_;  // crossings seen in the stream's candidates
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_STREAM_EVIDENCE_H_
