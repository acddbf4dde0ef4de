// The enrollment manifest (client/datasets/enroll_manifest.h, issue 34): file,crossing,heading
// [,position] lines for images whose names are not headings, with views of no heading.
#include "client/datasets/enroll_manifest.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteImage;

class EnrollManifestTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* name : {"p0_i0.JPG", "p0_i1.JPG", "p1_i0.png", "a b.jpeg", "p2.jpg"}) {
      WriteImage(dir_.Make(std::string("photos/") + name), 20, 20, cv::Scalar(1, 2, 3));
    }
  }
  absl::StatusOr<std::vector<EnrollImage>> Parse(const std::string& text) {
    return ParseEnrollManifest(text, dir_.path());
  }
  ScopedTempDir dir_;
};

TEST_F(EnrollManifestTest, ReadsFilesCrossingsHeadingsAndPositionsInOrder) {
  auto images = Parse(
      "file,crossing,heading,position\r\n"
      "# a comment\n"
      "\n"
      "photos/p0_i0.JPG,main-and-1st,030,north-kerb\n"
      "photos/p0_i1.JPG, main-and-1st ,292.5\n"
      "\"photos/a b.jpeg\",\"Main St, 1st Ave\",,\"p \"\"2\"\"\"\n"
      "photos/p1_i0.png,station,unknown\n");
  ASSERT_TRUE(images.ok()) << images.status();
  ASSERT_EQ(images->size(), 4u);
  const auto& v = *images;
  EXPECT_EQ(v[0].path, dir_.path() / "photos/p0_i0.JPG");
  EXPECT_EQ(v[0].crossing, "main-and-1st");
  EXPECT_EQ(v[0].heading_deg, 30);
  EXPECT_EQ(v[0].position, "north-kerb");
  EXPECT_EQ(v[1].crossing, "main-and-1st");  // spaces around an unquoted field are dropped
  EXPECT_EQ(v[1].heading_deg, 292.5);
  EXPECT_EQ(v[1].position, "");
  EXPECT_EQ(v[2].crossing, "Main St, 1st Ave");
  EXPECT_FALSE(HasHeading(v[2]));
  EXPECT_EQ(v[2].position, "p \"2\"");
  EXPECT_TRUE(HasHeading(v[1]));
  EXPECT_FALSE(HasHeading(v[3]));
  EXPECT_TRUE(std::isnan(v[3].heading_deg));
}

TEST_F(EnrollManifestTest, WithoutAHeaderAndWithAbsolutePaths) {
  const std::string absolute = (dir_.path() / "photos/p1_i0.png").string();
  auto images = Parse(absolute + ",x,-\n");
  ASSERT_TRUE(images.ok()) << images.status();
  ASSERT_EQ(images->size(), 1u);
  EXPECT_EQ((*images)[0].path, absolute);
  EXPECT_FALSE(HasHeading((*images)[0]));
}

TEST_F(EnrollManifestTest, EveryProblemIsListedWithItsLine) {
  auto images = Parse(
      "file,crossing,heading\n"
      "photos/missing.jpg,a,0\n"         // 2: no such file
      "photos/p0_i0.JPG,a,400\n"         // 3: outside [0, 360)
      "photos/p0_i1.JPG,,10\n"           // 4: no crossing
      "photos/p1_i0.png,a,north\n"       // 5: not a number
      "notes.txt,a,0\n"                  // 6: not an image
      "photos/p1_i0.png,a,1,x,y\n"       // 7: too many fields
      "photos/a b.jpeg,b,90\n"
      "photos/a b.jpeg,c,90\n"           // 9: listed twice
      "photos/p2.jpg,b,90.0\n"           // 10: b's heading 90 again
      "\"photos/p0_i1.JPG,b,1\n");       // 11: unclosed quote
  ASSERT_FALSE(images.ok());
  EXPECT_EQ(images.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(images.status().message());
  EXPECT_THAT(message, HasSubstr("9 problems"));
  EXPECT_THAT(message, HasSubstr("line 2: "));
  EXPECT_THAT(message, HasSubstr("missing.jpg' does not exist"));
  EXPECT_THAT(message, HasSubstr("line 3: heading 400 is outside [0, 360)"));
  EXPECT_THAT(message, HasSubstr("line 4: no crossing"));
  EXPECT_THAT(message, HasSubstr("line 5: heading 'north' is not a number"));
  EXPECT_THAT(message, HasSubstr("line 6: 'notes.txt' is not an image"));
  EXPECT_THAT(message, HasSubstr("line 7: 5 fields"));
  EXPECT_THAT(message, HasSubstr("line 9: 'photos/a b.jpeg' is listed again (first on line 8)"));
  EXPECT_THAT(message, HasSubstr("line 10: crossing b has heading 90.0 already on line 8"));
  EXPECT_THAT(message, HasSubstr("line 11: a quoted field is not closed"));
}

TEST_F(EnrollManifestTest, ViewsOfNoHeadingMayShareACrossingAndPosition) {
  auto images = Parse("photos/p0_i0.JPG,a,\nphotos/p0_i1.JPG,a,\n");
  ASSERT_TRUE(images.ok()) << images.status();
  EXPECT_EQ(images->size(), 2u);
}

TEST_F(EnrollManifestTest, AnEmptyOrUnreadableManifestIsAnError) {
  EXPECT_EQ(Parse("file,crossing,heading\n").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ReadEnrollManifest(dir_.path() / "none.csv").status().code(),
            absl::StatusCode::kNotFound);
  {
    std::ofstream out(dir_.Make("m/views.csv"));
    out << "../photos/p0_i0.JPG,a,0\n";  // relative to the manifest's folder
  }
  auto images = ReadEnrollManifest(dir_.path() / "m/views.csv");
  ASSERT_TRUE(images.ok()) << images.status();
  EXPECT_EQ((*images)[0].path, dir_.path() / "m/../photos/p0_i0.JPG");
}

TEST_F(EnrollManifestTest, AFolderOfAnyNamesEnrollsWithNoHeadings) {
  auto images = ScanUnheadedFolder(dir_.path());
  ASSERT_TRUE(images.ok()) << images.status();
  ASSERT_EQ(images->size(), 5u);
  for (const EnrollImage& image : *images) {
    EXPECT_EQ(image.crossing, "photos");
    EXPECT_FALSE(HasHeading(image));
  }
}

}  // namespace
}  // namespace waymark::cli
