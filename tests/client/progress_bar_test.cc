#include "client/common/progress_bar.h"

#include <gtest/gtest.h>

#include <sstream>

namespace waymark::cli {
namespace {

TEST(FormatProgressTest, FillsProportionally) {
  EXPECT_EQ(FormatProgress(0, 360, "views", 10), "[          ] 0/360 views");
  EXPECT_EQ(FormatProgress(180, 360, "views", 10), "[#####     ] 180/360 views");
  EXPECT_EQ(FormatProgress(360, 360, "views", 10), "[##########] 360/360 views");
  EXPECT_EQ(FormatProgress(5, 0, "views", 4), "[####] 5/0 views");
}

TEST(ProgressBarTest, SilentWhenDisabled) {
  std::ostringstream out;
  {
    ProgressBar bar(out, 3, "views", /*enabled=*/false);
    bar.Update(1);
    bar.Update(3);
  }
  EXPECT_EQ(out.str(), "");
}

TEST(ProgressBarTest, RedrawsInPlaceAndEndsTheLine) {
  std::ostringstream out;
  ProgressBar bar(out, 2, "views", /*enabled=*/true);
  bar.Update(1);
  bar.Update(2);
  bar.Finish();
  bar.Finish();  // idempotent
  EXPECT_EQ(out.str(),
            "\r" + FormatProgress(1, 2, "views") + "\r" + FormatProgress(2, 2, "views") + "\n");
}

TEST(FormatProgressTest, AppendsTheDetail) {
  EXPECT_EQ(FormatProgress(3, 4, "views", 4, "2 stored, 1 duplicate"),
            "[### ] 3/4 views: 2 stored, 1 duplicate");
}

TEST(ProgressBarTest, PadsAShorterLineOverTheLongerOne) {
  std::ostringstream out;
  ProgressBar bar(out, 2, "views", /*enabled=*/true);
  bar.Update(1, "12345");
  bar.Update(2, "1");
  const std::string first = FormatProgress(1, 2, "views", 30, "12345");
  const std::string second = FormatProgress(2, 2, "views", 30, "1");
  EXPECT_EQ(out.str(), "\r" + first + "\r" + second + std::string(first.size() - second.size(), ' '));
}

}  // namespace
}  // namespace waymark::cli
