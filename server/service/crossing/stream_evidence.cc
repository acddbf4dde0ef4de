#include "server/service/crossing/stream_evidence.h"

#include <vector>

namespace waymark::service {

void StreamEvidence::Apply(const crossing::RecognitionOptions& options,
                           v1::RecognizeResponse* response) {
  if (options.mode != crossing::RecognitionMode::kRetrieval || options.evidence_threshold <= 0) {
    return;
  }
  if (!filter_ || threshold_ != options.evidence_threshold) {
    crossing::EvidenceOptions evidence;
    evidence.threshold = options.evidence_threshold;
    filter_.emplace(evidence);
    threshold_ = options.evidence_threshold;
  }
  std::vector<crossing::FrameEvidence> frame;
  for (const v1::Candidate& c : response->candidates()) {
    frame.push_back({c.crossing_id(), c.log10_nfa()});
    names_[c.crossing_id()] = c.crossing();
  }
  if (response->global_model()) {
    // The global path's chance model, weak frames included (place_evidence.h).
    frame.push_back(crossing::GlobalFrameEvidence(response->global_crossing_id(),
                                                  response->global_log10_false_alarms()));
    names_[response->global_crossing_id()] = response->global_crossing();
  } else if (response->accepted_by_global()) {
    frame.push_back(crossing::GlobalAnswerEvidence(response->crossing_id(), filter_->options()));
    names_[response->crossing_id()] = response->crossing();
  }
  const crossing::PlaceBelief& belief = filter_->Update(frame);

  v1::StreamEvidence* out = response->mutable_evidence();
  out->set_frame_recognized(response->recognized());
  out->set_posterior(belief.posterior);
  out->set_unknown(belief.unknown);
  out->set_frames(belief.frames);
  out->set_frames_since_change(belief.frames_since_change);
  if (belief.crossing_id >= 0) {
    out->set_crossing_id(belief.crossing_id);
    out->set_crossing(names_[belief.crossing_id]);
  }
  // The answer is the belief's; the view and heading this frame's best of that crossing.
  response->set_recognized(belief.recognized);
  response->clear_crossing_id();
  response->clear_crossing();
  response->clear_view_id();
  response->clear_heading_deg();
  response->clear_position();
  if (!belief.recognized) {
    response->set_accepted_by("refused");
    if (response->reason().empty()) {
      response->set_reason("evidence over the frames so far is below the threshold");
    }
    return;
  }
  response->set_reason("");
  response->set_accepted_by("stream_evidence");
  response->set_crossing_id(belief.crossing_id);
  response->set_crossing(names_[belief.crossing_id]);
  const v1::Candidate* best = nullptr;
  for (const v1::Candidate& c : response->candidates()) {
    if (c.crossing_id() == belief.crossing_id && (!best || c.log10_nfa() < best->log10_nfa())) {
      best = &c;
    }
  }
  if (best) {
    response->set_view_id(best->view_id());
    response->set_heading_deg(best->heading_deg());
    response->set_position(best->position());
  } else if (response->global_model() && response->global_crossing_id() == belief.crossing_id) {
    response->set_view_id(response->global_view_id());
  }
}

}  // namespace waymark::service
