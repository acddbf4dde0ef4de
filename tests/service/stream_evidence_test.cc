// StreamEvidence (StreamRecognize's belief over frames, retrieval mode): frames the global path
// answered count for their crossing though they carry no candidate with an NFA.

#include "server/service/stream_evidence.h"

#include "gtest/gtest.h"

namespace waymark::service {
namespace {

crossing::RecognitionOptions Retrieval() {
  crossing::RecognitionOptions options;
  options.mode = crossing::RecognitionMode::kRetrieval;
  return options;
}

// A frame the global path accepted as crossing 7 without any match set.
v1::RecognizeResponse GlobalAnswer() {
  v1::RecognizeResponse r;
  r.set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  r.set_recognized(true);
  r.set_accepted_by_global(true);
  r.set_crossing_id(7);
  r.set_crossing("north");
  r.set_global_lift(0.2);
  return r;
}

TEST(StreamEvidenceTest, FramesAcceptedByTheGlobalPathBuildTheBeliefTwoDecide) {
  StreamEvidence evidence;
  v1::RecognizeResponse first = GlobalAnswer();
  evidence.Apply(Retrieval(), &first);
  EXPECT_FALSE(first.recognized());  // one frame does not decide alone
  EXPECT_TRUE(first.evidence().frame_recognized());
  EXPECT_EQ(first.evidence().crossing(), "north");
  EXPECT_GT(first.evidence().posterior(), 0.5);

  v1::RecognizeResponse second = GlobalAnswer();
  evidence.Apply(Retrieval(), &second);
  EXPECT_TRUE(second.recognized());
  EXPECT_EQ(second.crossing_id(), 7);
  EXPECT_EQ(second.crossing(), "north");
  EXPECT_GE(second.evidence().posterior(), 0.95);
}

TEST(StreamEvidenceTest, AFrameWithoutCandidatesOrGlobalAnswerNamesNothing) {
  StreamEvidence evidence;
  v1::RecognizeResponse nothing;
  nothing.set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  for (int i = 0; i < 3; ++i) {
    v1::RecognizeResponse frame = nothing;
    evidence.Apply(Retrieval(), &frame);
    EXPECT_FALSE(frame.recognized());
    EXPECT_EQ(frame.evidence().crossing_id(), 0);
  }
}

}  // namespace
}  // namespace waymark::service
