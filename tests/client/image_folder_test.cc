#include "client/datasets/image_folder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteImage;

const cv::Scalar kGrey(128, 128, 128);

TEST(ParseHeadingTest, ReadsDecimalStems) {
  EXPECT_DOUBLE_EQ(*ParseHeading("views/A/030.jpg"), 30.0);
  EXPECT_DOUBLE_EQ(*ParseHeading("30.5.png"), 30.5);
  EXPECT_DOUBLE_EQ(*ParseHeading("0.jpeg"), 0.0);
  EXPECT_DOUBLE_EQ(*ParseHeading("359.9.jpg"), 359.9);
}

TEST(ParseHeadingTest, NormalisesIntoOneTurn) {
  EXPECT_DOUBLE_EQ(*ParseHeading("360.jpg"), 0.0);
  EXPECT_DOUBLE_EQ(*ParseHeading("390.jpg"), 30.0);
  EXPECT_DOUBLE_EQ(*ParseHeading("-30.jpg"), 330.0);
}

TEST(ParseHeadingTest, RejectsNonNumericStemsNamingTheFile) {
  for (const char* name :
       {"north.jpg", "30deg.jpg", " 30.jpg", "nan.jpg", "inf.png", ".jpg", "0x1e.png", "+30.jpg"}) {
    auto heading = ParseHeading(std::string("dir/A/") + name);
    ASSERT_FALSE(heading.ok()) << name;
    EXPECT_EQ(heading.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(heading.status().message(), HasSubstr(name));
  }
}

TEST(IsImageFileTest, KnowsTheThreeExtensionsInAnyCase) {
  EXPECT_TRUE(IsImageFile("a/000.jpg"));
  EXPECT_TRUE(IsImageFile("a/000.JPEG"));
  EXPECT_TRUE(IsImageFile("a/000.Png"));
  EXPECT_FALSE(IsImageFile("a/000.gif"));
  EXPECT_FALSE(IsImageFile("a/README"));
  EXPECT_FALSE(IsImageFile("a/jpg"));
}

TEST(ScanEnrollFolderTest, SortsByCrossingThenHeadingAndSkipsOtherFiles) {
  ScopedTempDir dir;
  WriteImage(dir.Make("B/090.png"), 8, 6, kGrey);
  WriteImage(dir.Make("B/030.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/330.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("A/30.5.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/300.jpeg"), 8, 6, kGrey);
  WriteImage(dir.Make(".cache/x.png"), 8, 6, kGrey);  // hidden folder
  WriteImage(dir.Make("A/.thumb.png"), 8, 6, kGrey);  // hidden file
  std::ofstream(dir.Make("A/notes.txt")) << "not an image";
  std::ofstream(dir.Make("README.md")) << "top-level text is fine";

  auto images = ScanEnrollFolder(dir.path());
  ASSERT_TRUE(images.ok()) << images.status();
  ASSERT_EQ(images->size(), 5u);
  std::vector<std::pair<std::string, double>> order;
  for (const EnrollImage& image : *images) order.emplace_back(image.crossing, image.heading_deg);
  EXPECT_THAT(order, ::testing::ElementsAre(std::pair<std::string, double>{"A", 30.5},
                                            std::pair<std::string, double>{"A", 300},
                                            std::pair<std::string, double>{"A", 330},
                                            std::pair<std::string, double>{"B", 30},
                                            std::pair<std::string, double>{"B", 90}));
  EXPECT_EQ((*images)[0].path, dir.path() / "A/30.5.png");
}

TEST(ScanEnrollFolderTest, NonNumericStemIsAnErrorNamingTheFile) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/front.png"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(images.status().message(), HasSubstr("front.png"));
}

TEST(ScanEnrollFolderTest, ImageOutsideACrossingFolderIsAnError) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.png"), 8, 6, kGrey);
  WriteImage(dir.Make("090.png"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(images.status().message(), HasSubstr("090.png"));
}

TEST(ScanEnrollFolderTest, MissingOrEmptyFolderIsAnError) {
  ScopedTempDir dir;
  EXPECT_EQ(ScanEnrollFolder(dir.path() / "nope").status().code(), absl::StatusCode::kNotFound);
  std::filesystem::create_directories(dir.path() / "A");
  EXPECT_EQ(ScanEnrollFolder(dir.path()).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ScanQueryFolderTest, KeepsAnyStemAndMarksUnknown) {
  ScopedTempDir dir;
  WriteImage(dir.Make("unknown/park.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("B/045.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/q2.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/q1.jpg"), 8, 6, kGrey);

  auto queries = ScanQueryFolder(dir.path());
  ASSERT_TRUE(queries.ok()) << queries.status();
  ASSERT_EQ(queries->size(), 4u);
  EXPECT_EQ((*queries)[0].path.filename(), "q1.jpg");
  EXPECT_EQ((*queries)[1].path.filename(), "q2.png");
  EXPECT_EQ((*queries)[2].folder, "B");
  ASSERT_TRUE((*queries)[2].heading_deg.has_value());
  EXPECT_DOUBLE_EQ(*(*queries)[2].heading_deg, 45);
  EXPECT_FALSE((*queries)[0].heading_deg.has_value());
  EXPECT_FALSE((*queries)[0].unknown());
  EXPECT_TRUE((*queries)[3].unknown());
}

}  // namespace
}  // namespace waymark::cli
