#include "client/cli/recognition_flags.h"

#include <gtest/gtest.h>

#include <map>

#include "server/crossing/options.h"

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

// Issue 34: the global path's false-alarm bound is a per-request override like the NFA's.
TEST(RecognitionFlagsTest, TheGlobalPathsFalseAlarmBoundIsAnOverride) {
  EXPECT_FALSE(Parse({}).has_max_log10_global_efa());
  const v1::RecognitionParams params = Parse({"--max-log10-global-efa", "-3"});
  EXPECT_DOUBLE_EQ(params.max_log10_global_efa(), -3.0);
  EXPECT_THROW(Parse({"--max-log10-global-efa", "1000"}), CLI::ValidationError);
}

// The default an option's help shows, "[X]" at its end ("" without one).
std::string ShownDefault(const CLI::Option& option) {
  const std::string text = option.get_description();
  const size_t open = text.rfind('[');
  if (text.empty() || text.back() != ']' || open == std::string::npos) return "";
  return text.substr(open + 1, text.size() - open - 2);
}

// Issue 35's tour: `recognize --help` and `eval --help` showed `--min-global-lift ... [0.16]`
// while a database's default is 0 (the lift rule off). Every default the overrides show is the
// server's (crossing::RecognitionOptions, which a new database keeps), and none goes unchecked.
TEST(RecognitionFlagsTest, TheHelpShowsTheServersDefaults) {
  CLI::App app;
  RecognitionFlags flags;
  flags.Register(&app);
  const crossing::RecognitionOptions server;
  const std::map<std::string, double> defaults = {
      {"--min-global-lift", server.min_global_lift},
      {"--max-log10-nfa", server.max_log10_nfa},
      {"--max-log10-global-efa", server.max_log10_global_efa},
      {"--global-shortlist", server.global_shortlist},
      {"--evidence", server.evidence_threshold},
  };
  int shown = 0;
  for (const CLI::Option* option : app.get_options()) {
    const std::string value = ShownDefault(*option);
    if (value.empty()) continue;
    ++shown;
    const std::string name = option->get_name(false, true);
    const auto it = defaults.find(name);
    ASSERT_NE(it, defaults.end()) << name << " shows [" << value << "], which is not checked";
    EXPECT_DOUBLE_EQ(std::stod(value), it->second) << name << " shows [" << value << "]";
  }
  EXPECT_EQ(shown, static_cast<int>(defaults.size()));
}

}  // namespace
}  // namespace waymark::cli
