// StreamEvidence (StreamRecognize's belief over frames, retrieval mode): frames the global path
// answered count for their crossing though they carry no candidate with an NFA.

#include "server/service/crossing/stream_evidence.h"

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

// Issue 34: a frame the global path did not accept alone (a weak frame: its chance model
// expects 10^-1.2 false alarms) still counts for the crossing of its most similar view; agreeing
// weak frames decide, and the answer says it was the stream's evidence.
TEST(StreamEvidenceTest, WeakGlobalFramesDecideOverTheStreamAndSaySo) {
  StreamEvidence evidence;
  v1::RecognizeResponse weak;
  weak.set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  weak.set_accepted_by("refused");
  weak.set_global_stage(true);
  weak.set_global_model(true);
  weak.set_global_crossing_id(9);
  weak.set_global_crossing("south");
  weak.set_global_view_id(90);
  weak.set_global_log10_false_alarms(-1.2);
  v1::RecognizeResponse frame = weak;
  evidence.Apply(Retrieval(), &frame);
  EXPECT_FALSE(frame.recognized());
  EXPECT_EQ(frame.accepted_by(), "refused");
  EXPECT_EQ(frame.evidence().crossing(), "south");
  int frames = 1;
  while (!frame.recognized() && frames < 20) {
    frame = weak;
    evidence.Apply(Retrieval(), &frame);
    ++frames;
  }
  EXPECT_TRUE(frame.recognized());
  EXPECT_LE(frames, 8);
  EXPECT_EQ(frame.crossing(), "south");
  EXPECT_EQ(frame.accepted_by(), "stream_evidence");
  EXPECT_EQ(frame.view_id(), 90);
}

}  // namespace
}  // namespace waymark::service
