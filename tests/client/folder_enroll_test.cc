// EnrollFolder (client/sessions/folder_enroll.h) against the in-memory fake CrossingService: the
// tally counts the server's answers (stored, duplicate, invalid), a stop sends nothing more and
// waits for the views in flight, an error keeps what was stored and says what ended it.

#include "client/sessions/folder_enroll.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <memory>
#include <vector>

#include "client/datasets/image_folder.h"
#include "client/lib/channel.h"
#include "tests/client/fake_crossing_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::FakeServer;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteImage;

class FolderEnrollTest : public ::testing::Test {
 protected:
  void SetUp() override {
    client_ = std::make_unique<client::CrossingClient>(client::MakeChannel(server_.address()));
    v1::CreateDatabaseRequest create;
    create.set_name("campus");
    ASSERT_TRUE(client_->CreateDatabase(create).ok());
    options_.database = "campus";
  }

  // `views` images at A/000, A/030, ..., all different.
  std::vector<EnrollImage> MakeFolder(int views) {
    for (int k = 0; k < views; ++k) {
      char name[16];
      std::snprintf(name, sizeof(name), "A/%03d.png", 30 * k);
      WriteImage(dir_.Make(name), 16, 12, cv::Scalar(10 * k, 0, 255 - 10 * k));
    }
    absl::StatusOr<std::vector<EnrollImage>> images = ScanEnrollFolder(dir_.path());
    EXPECT_TRUE(images.ok()) << images.status();
    return images.ok() ? *images : std::vector<EnrollImage>();
  }

  FolderEnrollReport Enroll(const std::vector<EnrollImage>& images,
                            const EnrollProgress& progress = {}) {
    return EnrollFolder(*client_, images, options_, no_stop_, progress);
  }

  FakeServer server_;
  std::unique_ptr<client::CrossingClient> client_;
  ScopedTempDir dir_;
  FolderEnrollOptions options_;
  std::atomic<bool> no_stop_{false};
};

TEST_F(FolderEnrollTest, TallyAndProgressCountAnswersNotViewsSent) {
  std::vector<EnrollImage> images = MakeFolder(4);
  std::ofstream(dir_.Make("A/300.png"));  // empty: the fake's invalid view
  images = *ScanEnrollFolder(dir_.path());

  std::vector<EnrollTally> seen;
  FolderEnrollReport first = Enroll(images, [&](const EnrollTally& t) { seen.push_back(t); });
  ASSERT_TRUE(first.status.ok()) << first.status;
  EXPECT_FALSE(first.stopped);
  EXPECT_EQ(first.tally.total, 5);
  EXPECT_EQ(first.tally.stored, 4);
  EXPECT_EQ(first.tally.invalid, 1);
  EXPECT_EQ(first.tally.duplicates, 0);
  EXPECT_EQ(first.tally.crossings_created, 1);
  ASSERT_EQ(seen.size(), 5u);
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i].answered(), static_cast<int>(i) + 1);
  ASSERT_EQ(first.invalid.size(), 1u);
  EXPECT_EQ(first.invalid[0].image.path, dir_.path() / "A/300.png");
  EXPECT_THAT(first.invalid[0].answer.error_message(), HasSubstr("empty"));

  // Again: every image is already stored.
  FolderEnrollReport second = Enroll(images);
  ASSERT_TRUE(second.status.ok()) << second.status;
  EXPECT_EQ(second.tally.stored, 0);
  EXPECT_EQ(second.tally.duplicates, 4);
  EXPECT_EQ(second.tally.invalid, 1);
  EXPECT_EQ(second.tally.remaining(), 0);
  EXPECT_EQ(server_.service().views("campus").size(), 4u);
  EXPECT_EQ(DescribeOutcomes(second.tally),
            "0 stored, 4 skipped as duplicates, 1 skipped as invalid");
}

TEST_F(FolderEnrollTest, ReplaceStoresAChangedImageInPlaceOfTheOldOne) {
  const std::vector<EnrollImage> images = MakeFolder(3);
  ASSERT_TRUE(Enroll(images).status.ok());
  WriteImage(dir_.path() / "A/030.png", 16, 12, cv::Scalar(1, 2, 3));  // re-shot

  options_.replace = true;
  FolderEnrollReport report = Enroll(images);
  ASSERT_TRUE(report.status.ok()) << report.status;
  EXPECT_EQ(report.tally.stored, 1);
  EXPECT_EQ(report.tally.replaced, 1);
  EXPECT_EQ(report.tally.duplicates, 2);
  EXPECT_EQ(server_.service().views("campus").size(), 3u);
  EXPECT_EQ(DescribeOutcomes(report.tally),
            "1 stored (replacing 1 older views), 2 skipped as duplicates, 0 skipped as invalid");
}

// One view in flight at a time and the stop requested on the second answer: exactly two views
// were sent, both answered and stored, nothing else.
TEST_F(FolderEnrollTest, AStopSendsNoMoreViewsAndWaitsForTheAnswersInFlight) {
  const std::vector<EnrollImage> images = MakeFolder(6);
  options_.window = 1;
  std::atomic<bool> stop{false};
  FolderEnrollReport report =
      EnrollFolder(*client_, images, options_, stop, [&](const EnrollTally& t) {
        if (t.answered() == 2) stop = true;
      });
  ASSERT_TRUE(report.status.ok()) << report.status;
  EXPECT_TRUE(report.stopped);
  EXPECT_EQ(report.tally.sent, 2);
  EXPECT_EQ(report.tally.stored, 2);
  EXPECT_EQ(report.tally.remaining(), 4);
  EXPECT_EQ(server_.service().views("campus").size(), 2u);
}

// With several views in flight, whatever was sent before the stop is answered before the report:
// the report and the server agree on every view.
TEST_F(FolderEnrollTest, AStopWithViewsInFlightStillAccountsForEveryViewSent) {
  const std::vector<EnrollImage> images = MakeFolder(8);
  options_.window = 3;
  std::atomic<bool> stop{false};
  FolderEnrollReport report =
      EnrollFolder(*client_, images, options_, stop, [&](const EnrollTally&) { stop = true; });
  ASSERT_TRUE(report.status.ok()) << report.status;
  EXPECT_TRUE(report.stopped);
  EXPECT_EQ(report.tally.answered(), report.tally.sent);
  EXPECT_LE(report.tally.sent, 1 + options_.window);
  EXPECT_LT(report.tally.sent, 8);
  EXPECT_EQ(static_cast<int>(server_.service().views("campus").size()), report.tally.stored);
}

TEST_F(FolderEnrollTest, AServerErrorEndsItKeepingTheViewsStoredBeforeIt) {
  std::vector<EnrollImage> images = MakeFolder(4);
  std::ofstream(dir_.Make("A/075.png"));  // empty, fourth in heading order
  images = *ScanEnrollFolder(dir_.path());
  options_.strict = true;
  FolderEnrollReport report = Enroll(images);
  EXPECT_EQ(report.status.code(), absl::StatusCode::kInvalidArgument) << report.status;
  EXPECT_FALSE(report.stopped);
  EXPECT_EQ(report.tally.stored, 3);
  EXPECT_EQ(report.tally.remaining(), 2);
  EXPECT_EQ(server_.service().views("campus").size(), 3u);
}

TEST_F(FolderEnrollTest, AFileThatVanishedStopsItNamingTheFile) {
  const std::vector<EnrollImage> images = MakeFolder(4);
  std::filesystem::remove(dir_.path() / "A/060.png");
  FolderEnrollReport report = Enroll(images);
  EXPECT_EQ(report.status.code(), absl::StatusCode::kNotFound) << report.status;
  EXPECT_THAT(std::string(report.status.message()), HasSubstr("060.png"));
  EXPECT_EQ(report.tally.stored, 2);
  EXPECT_EQ(report.tally.remaining(), 2);
  EXPECT_EQ(server_.service().views("campus").size(), 2u);
}

}  // namespace
}  // namespace waymark::cli
