#include "client/cli/recognition_flags.h"

#include <gtest/gtest.h>

namespace waymark::cli {
namespace {

v1::RecognitionParams Parse(std::vector<std::string> args) {
  CLI::App app;
  RecognitionFlags flags;
  flags.Register(&app);
  std::reverse(args.begin(), args.end());  // CLI11 parses a reversed vector
  app.parse(args);
  return flags.ToParams();
}

TEST(RecognitionFlagsTest, NothingGivenSetsNothing) {
  const v1::RecognitionParams params = Parse({});
  EXPECT_FALSE(params.has_mode());
  EXPECT_FALSE(params.has_ratio());
  EXPECT_FALSE(params.has_n0());
  EXPECT_FALSE(params.has_min_inliers());
}

TEST(RecognitionFlagsTest, SetsExactlyTheGivenOnes) {
  const v1::RecognitionParams params =
      Parse({"--mode", "VERIFIED", "--ratio", "0.6", "--n2", "4", "--min-inliers", "0"});
  EXPECT_EQ(params.mode(), v1::RECOGNITION_MODE_VERIFIED);
  EXPECT_DOUBLE_EQ(params.ratio(), 0.6);
  EXPECT_EQ(params.n2(), 4);
  ASSERT_TRUE(params.has_min_inliers());  // an explicit zero is still an override
  EXPECT_EQ(params.min_inliers(), 0);
  EXPECT_FALSE(params.has_n0());
  EXPECT_FALSE(params.has_n1());
  EXPECT_FALSE(params.has_alpha());
  EXPECT_FALSE(params.has_beta());
}

TEST(RecognitionFlagsTest, AllOverrides) {
  const v1::RecognitionParams params =
      Parse({"--mode", "paper", "--n0", "3", "--n1", "8", "--alpha", "0.7", "--beta", "0.3"});
  EXPECT_EQ(params.mode(), v1::RECOGNITION_MODE_PAPER);
  EXPECT_EQ(params.n0(), 3);
  EXPECT_EQ(params.n1(), 8);
  EXPECT_DOUBLE_EQ(params.alpha(), 0.7);
  EXPECT_DOUBLE_EQ(params.beta(), 0.3);
}

TEST(RecognitionFlagsTest, RejectsBadValues) {
  EXPECT_THROW(Parse({"--mode", "fast"}), CLI::ValidationError);
  EXPECT_THROW(Parse({"--ratio", "1.5"}), CLI::ValidationError);
  EXPECT_THROW(Parse({"--n2", "0"}), CLI::ValidationError);
}

}  // namespace
}  // namespace waymark::cli
