#include "client/datasets/image_folder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteImage;

const cv::Scalar kGrey(128, 128, 128);

TEST(ParseHeadingTest, ReadsDecimalStems) {
  EXPECT_DOUBLE_EQ(*ParseHeading("views/A/030.jpg"), 30.0);
  EXPECT_DOUBLE_EQ(*ParseHeading("30.5.png"), 30.5);
  EXPECT_DOUBLE_EQ(*ParseHeading("0.jpeg"), 0.0);
  EXPECT_DOUBLE_EQ(*ParseHeading("359.9.jpg"), 359.9);
}

TEST(ParseHeadingTest, RefusesHeadingsOutsideOneTurnInsteadOfWrappingThem) {
  for (const char* name : {"360.jpg", "400.jpg", "999.9.png"}) {
    auto heading = ParseHeading(std::string("dir/A/") + name);
    ASSERT_FALSE(heading.ok()) << name << " read as " << *heading;
    EXPECT_EQ(heading.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(heading.status().message(), HasSubstr(name));
    EXPECT_THAT(heading.status().message(), HasSubstr("outside [0, 360)"));
  }
}

TEST(ParseHeadingTest, RefusesFrameNumbersWithMoreThanThreeDigits) {
  for (const char* name : {"0000110.jpg", "0030.jpg", "1234.5.png"}) {
    auto heading = ParseHeading(std::string("dir/A/") + name);
    ASSERT_FALSE(heading.ok()) << name << " read as " << *heading;
    EXPECT_THAT(heading.status().message(), HasSubstr(name));
    EXPECT_THAT(heading.status().message(), HasSubstr("a heading at most 3"));
  }
}

TEST(ParseHeadingTest, RejectsStemsThatAreNotHeadingsNamingTheFile) {
  for (const char* name : {"north.jpg", "30deg.jpg", " 30.jpg", "nan.jpg", "inf.png", ".jpg",
                           "0x1e.png", "+30.jpg", "-30.jpg", "1e2.jpg", "30..jpg", ".5.jpg",
                           "30.5.5.png"}) {
    auto heading = ParseHeading(std::string("dir/A/") + name);
    ASSERT_FALSE(heading.ok()) << name << " read as " << *heading;
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

TEST(ScanEnrollFolderTest, EveryBadFileNameIsReportedAtOnceWithTheExpectedLayout) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/front.png"), 8, 6, kGrey);
  WriteImage(dir.Make("B/400.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("C/0000110.jpg"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(images.status().message());
  EXPECT_THAT(message, HasSubstr((dir.path() / "A/front.png").string()));
  EXPECT_THAT(message, HasSubstr((dir.path() / "B/400.jpg").string()));
  EXPECT_THAT(message, HasSubstr((dir.path() / "C/0000110.jpg").string()));
  EXPECT_THAT(message, HasSubstr("DIR/<crossing>/<heading_deg>.jpg"));
  // In path order, whatever order the file system lists them in.
  EXPECT_LT(message.find("front.png"), message.find("400.jpg"));
  EXPECT_LT(message.find("400.jpg"), message.find("0000110.jpg"));
}

TEST(ScanEnrollFolderTest, ANumberedFrameFolderIsNotTakenForHeadings) {
  ScopedTempDir dir;
  for (int frame = 100; frame < 112; ++frame) {
    WriteImage(dir.Make("walk/" + std::string(7 - std::to_string(frame).size(), '0') +
                        std::to_string(frame) + ".jpg"),
               8, 6, kGrey);
  }
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_THAT(images.status().message(), HasSubstr("0000100.jpg"));
  EXPECT_THAT(images.status().message(), HasSubstr("frame number"));
  EXPECT_THAT(images.status().message(), HasSubstr("... and 2 more"));  // 10 listed of 12
}

TEST(ScanEnrollFolderTest, ANestedLayoutSaysWhereTheImagesAreAndWhatIsExpected) {
  ScopedTempDir dir;
  WriteImage(dir.Make("a/b/c/000.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("a/b/c/090.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("a/d/e/f/000.jpg"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(images.status().message());
  EXPECT_THAT(message, HasSubstr("found images in " + (dir.path() / "a/b/c").string() +
                                 "/: one level too deep?"));
  EXPECT_THAT(message, HasSubstr((dir.path() / "a/d/e/f").string() + "/"));
  EXPECT_THAT(message, HasSubstr("DIR/<crossing>/<heading_deg>.jpg"));
  EXPECT_THAT(message, HasSubstr("DIR/<crossing>/<position>/<heading_deg>.jpg"));
  EXPECT_THAT(message, Not(HasSubstr("no .jpg/.jpeg/.png images found")));
}

// DIR/<crossing>/<position>/<heading>: the folder names the view's position; crossings of either
// layout sit side by side.
TEST(ScanEnrollFolderTest, PositionFoldersTagTheirViews) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/p2/000.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("A/north-kerb/090.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("A/north-kerb/000.jpg"), 8, 6, kGrey);
  std::ofstream(dir.Make("A/empty/notes.txt")) << "x";  // no images: not a position
  WriteImage(dir.Make("B/030.png"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_TRUE(images.ok()) << images.status();
  ASSERT_EQ(images->size(), 4u);
  EXPECT_EQ((*images)[0].crossing, "A");
  EXPECT_EQ((*images)[0].position, "north-kerb");
  EXPECT_EQ((*images)[0].heading_deg, 0);
  EXPECT_EQ((*images)[1].position, "north-kerb");
  EXPECT_EQ((*images)[1].heading_deg, 90);
  EXPECT_EQ((*images)[2].position, "p2");
  EXPECT_EQ((*images)[2].path, dir.path() / "A/p2/000.jpg");
  EXPECT_EQ((*images)[3].crossing, "B");
  EXPECT_EQ((*images)[3].position, "");
  EXPECT_EQ((*images)[3].heading_deg, 30);
}

TEST(ScanEnrollFolderTest, ACrossingFolderWithImagesAndPositionFoldersIsAnErrorNamingBoth) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("A/north-kerb/090.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("B/p1/000.jpg"), 8, 6, kGrey);  // fine
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(images.status().message());
  EXPECT_THAT(message, HasSubstr((dir.path() / "A").string() + "/ holds both images (e.g. " +
                                 (dir.path() / "A/000.jpg").string() +
                                 ") and position folders (e.g. " +
                                 (dir.path() / "A/north-kerb").string() + "/)"));
  EXPECT_THAT(message, Not(HasSubstr((dir.path() / "B").string() + "/ holds")));
}

TEST(ScanEnrollFolderTest, OneHeadingMayBeTakenFromEachPositionButOnlyOnce) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/p1/030.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("A/p2/030.jpg"), 8, 6, kGrey);
  ASSERT_TRUE(ScanEnrollFolder(dir.path()).ok());
  WriteImage(dir.Make("A/p2/30.png"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_THAT(images.status().message(), HasSubstr("both have heading 30"));
  EXPECT_THAT(images.status().message(), HasSubstr((dir.path() / "A/p2/30.png").string()));
  EXPECT_THAT(images.status().message(), Not(HasSubstr("A/p1/030.jpg")));
}

TEST(ScanEnrollFolderTest, ImagesBesideGoodOnesButTooDeepAreStillAnError) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.png"), 8, 6, kGrey);
  WriteImage(dir.Make("A/raw/000.png"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_THAT(images.status().message(), HasSubstr((dir.path() / "A/raw").string()));
}

TEST(ScanEnrollFolderTest, TwoFilesWithOneHeadingAreAnError) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/030.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make("A/30.png"), 8, 6, kGrey);
  WriteImage(dir.Make("B/030.jpg"), 8, 6, kGrey);  // another crossing: fine
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_THAT(images.status().message(), HasSubstr("both have heading 30"));
  EXPECT_THAT(images.status().message(), HasSubstr("30.png"));
}

TEST(ScanEnrollFolderTest, ImageOutsideACrossingFolderIsAnError) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.png"), 8, 6, kGrey);
  WriteImage(dir.Make("090.png"), 8, 6, kGrey);
  auto images = ScanEnrollFolder(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(images.status().message(), HasSubstr("090.png"));
  EXPECT_THAT(images.status().message(), HasSubstr("one level too shallow?"));
}

TEST(ScanEnrollFolderTest, MissingOrEmptyFolderIsAnError) {
  ScopedTempDir dir;
  EXPECT_EQ(ScanEnrollFolder(dir.path() / "nope").status().code(), absl::StatusCode::kNotFound);
  std::filesystem::create_directories(dir.path() / "A");
  auto empty = ScanEnrollFolder(dir.path());
  EXPECT_EQ(empty.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(empty.status().message(), HasSubstr("no .jpg/.jpeg/.png images found"));
  EXPECT_THAT(empty.status().message(), HasSubstr("DIR/<crossing>/<heading_deg>.jpg"));
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

TEST(ScanQueryFolderTest, ANestedLayoutIsAnErrorNamingTheFolder) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/x/q1.png"), 8, 6, kGrey);
  auto queries = ScanQueryFolder(dir.path());
  ASSERT_FALSE(queries.ok());
  EXPECT_THAT(queries.status().message(), HasSubstr((dir.path() / "A/x").string() + "/"));
  EXPECT_THAT(queries.status().message(), HasSubstr("one level too deep?"));
}

TEST(ListFolderImagesTest, ListsTheImagesDirectlyInTheFolderByName) {
  ScopedTempDir dir;
  WriteImage(dir.Make("b.png"), 8, 6, kGrey);
  WriteImage(dir.Make("a.jpg"), 8, 6, kGrey);
  WriteImage(dir.Make(".hidden.png"), 8, 6, kGrey);
  WriteImage(dir.Make("sub/c.png"), 8, 6, kGrey);  // not this folder's
  std::ofstream(dir.Make("notes.txt")) << "text";
  auto images = ListFolderImages(dir.path());
  ASSERT_TRUE(images.ok()) << images.status();
  EXPECT_THAT(*images, ::testing::ElementsAre(dir.path() / "a.jpg", dir.path() / "b.png"));
}

TEST(ListFolderImagesTest, SaysWhereImagesAreWhenNoneAreDirectlyInTheFolder) {
  ScopedTempDir dir;
  WriteImage(dir.Make("A/000.png"), 8, 6, kGrey);
  auto images = ListFolderImages(dir.path());
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(images.status().message(), HasSubstr((dir.path() / "A").string() + "/"));
  EXPECT_THAT(images.status().message(), HasSubstr("waymark eval"));

  ScopedTempDir empty;
  EXPECT_THAT(ListFolderImages(empty.path()).status().message(),
              HasSubstr("no .jpg/.jpeg/.png images found"));
  EXPECT_EQ(ListFolderImages(empty.path() / "nope").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace waymark::cli
