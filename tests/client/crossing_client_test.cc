#include "client/lib/crossing_client.h"
#include "client/lib/status_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "client/lib/channel.h"
#include "tests/client/fake_crossing_service.h"

namespace waymark::client {
namespace {

using ::testing::HasSubstr;
using waymark::testing::FakeServer;

// Fast retries so the tests do not sleep for real backoffs.
CrossingClientOptions FastRetries() {
  CrossingClientOptions options;
  options.timeout = absl::Seconds(10);
  options.retry.initial_backoff = absl::Milliseconds(1);
  options.retry.max_backoff = absl::Milliseconds(5);
  options.retry.max_attempts = 4;
  return options;
}

class CrossingClientTest : public ::testing::Test {
 protected:
  CrossingClientTest() : client_(MakeChannel(server_.address()), FastRetries()) {}

  void CreateDatabase(const std::string& name) {
    v1::CreateDatabaseRequest request;
    request.set_name(name);
    ASSERT_TRUE(client_.CreateDatabase(request).ok());
  }

  FakeServer server_;
  CrossingClient client_;
};

TEST_F(CrossingClientTest, UnaryCallsReturnTheResponse) {
  v1::CreateDatabaseRequest create;
  create.set_name("campus");
  create.mutable_params()->set_hue_bins(18);
  auto db = client_.CreateDatabase(create);
  ASSERT_TRUE(db.ok()) << db.status();
  EXPECT_EQ(db->name(), "campus");
  EXPECT_EQ(db->params().hue_bins(), 18);

  auto list = client_.ListDatabases();
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->databases_size(), 1);
  EXPECT_EQ(list->databases(0).name(), "campus");
}

TEST_F(CrossingClientTest, ServerErrorsKeepCodeAndMessage) {
  CreateDatabase("campus");
  v1::CreateDatabaseRequest again;
  again.set_name("campus");
  auto duplicate = client_.CreateDatabase(again);
  EXPECT_EQ(duplicate.status(), absl::AlreadyExistsError("database 'campus' already exists"));

  v1::GetDatabaseStatsRequest stats;
  stats.set_name("nowhere");
  EXPECT_EQ(client_.GetDatabaseStats(stats).status(),
            absl::NotFoundError("no crossing database named 'nowhere'"));
}

TEST_F(CrossingClientTest, ReadsAreRetriedOnUnavailable) {
  server_.service().FailNextWithUnavailable("ListDatabases", 2);
  auto list = client_.ListDatabases();
  EXPECT_TRUE(list.ok()) << list.status();
  EXPECT_EQ(server_.service().calls("ListDatabases"), 3);

  CreateDatabase("campus");
  server_.service().FailNextWithUnavailable("RecognizeCrossing", 1);
  v1::RecognizeRequest recognize;
  recognize.set_database("campus");
  EXPECT_TRUE(client_.RecognizeCrossing(recognize).ok());
  EXPECT_EQ(server_.service().calls("RecognizeCrossing"), 2);
}

TEST_F(CrossingClientTest, RetriesGiveUpAfterMaxAttempts) {
  server_.service().FailNextWithUnavailable("GetDatabaseStats", 10);
  v1::GetDatabaseStatsRequest request;
  request.set_name("campus");
  auto stats = client_.GetDatabaseStats(request);
  EXPECT_EQ(stats.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(stats.status().message(), "injected outage");
  EXPECT_TRUE(IsUnavailableCall(stats.status()));  // the command line names the server
  EXPECT_EQ(server_.service().calls("GetDatabaseStats"), 4);
}

TEST_F(CrossingClientTest, ServerAnswersAreNotRetried) {
  v1::GetDatabaseStatsRequest request;
  request.set_name("nowhere");
  EXPECT_EQ(client_.GetDatabaseStats(request).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(server_.service().calls("GetDatabaseStats"), 1);
}

TEST_F(CrossingClientTest, WritesAreNeverRetried) {
  server_.service().FailNextWithUnavailable("CreateDatabase", 1);
  v1::CreateDatabaseRequest request;
  request.set_name("campus");
  EXPECT_EQ(client_.CreateDatabase(request).status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(server_.service().calls("CreateDatabase"), 1);

  server_.service().FailNextWithUnavailable("DeleteDatabase", 1);
  v1::DeleteDatabaseRequest remove;
  remove.set_name("campus");
  EXPECT_EQ(client_.DeleteDatabase(remove).status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(server_.service().calls("DeleteDatabase"), 1);
}

TEST_F(CrossingClientTest, EveryUnaryCallHasADeadline) {
  CrossingClientOptions options = FastRetries();
  options.timeout = absl::Milliseconds(100);
  CrossingClient impatient(MakeChannel(server_.address()), options);
  server_.service().set_delay(absl::Milliseconds(600));
  // DEADLINE_EXCEEDED (not the answer the server gives after 600 ms) is the proof: how long the
  // call took is not asserted, a loaded machine may take longer to notice the deadline.
  EXPECT_EQ(impatient.ListDatabases().status().code(), absl::StatusCode::kDeadlineExceeded);
  server_.service().set_delay(absl::ZeroDuration());
}

TEST_F(CrossingClientTest, UnreachableServerIsUnavailable) {
  CrossingClientOptions options = FastRetries();
  options.timeout = absl::Seconds(5);
  // Port 1 on localhost: nothing listens, the connection is refused at once.
  CrossingClient nobody(MakeChannel("127.0.0.1:1"), options);
  EXPECT_EQ(nobody.ListDatabases().status().code(), absl::StatusCode::kUnavailable);
}

TEST_F(CrossingClientTest, BulkEnrollStreamsViewsAndSummarises) {
  CreateDatabase("campus");
  std::unique_ptr<BulkEnrollWriter> writer = client_.BulkEnroll();
  for (int heading = 0; heading < 360; heading += 30) {
    v1::EnrollViewRequest request;
    request.set_database("campus");
    request.set_crossing(heading < 180 ? "A" : "B");
    request.set_heading_deg(heading);
    request.mutable_image()->set_data("bytes" + std::to_string(heading));
    request.set_create_crossing(true);
    ASSERT_TRUE(writer->Write(request));
  }
  auto summary = writer->Finish();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->views(), 12);
  EXPECT_EQ(summary->crossings_created(), 2);
  EXPECT_EQ(server_.service().views("campus").size(), 12u);
  EXPECT_EQ(writer->Finish().status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST_F(CrossingClientTest, BulkEnrollReportsTheServersError) {
  std::unique_ptr<BulkEnrollWriter> writer = client_.BulkEnroll();
  v1::EnrollViewRequest request;
  request.set_database("missing");
  writer->Write(request);  // may or may not see the failure yet: writes are buffered
  EXPECT_EQ(writer->Finish().status(), absl::NotFoundError("no crossing database named 'missing'"));
}

TEST_F(CrossingClientTest, AbandonedStreamsAreCancelledCleanly) {
  CreateDatabase("campus");
  {
    std::unique_ptr<BulkEnrollWriter> writer = client_.BulkEnroll();
    v1::EnrollViewRequest request;
    request.set_database("campus");
    writer->Write(request);
  }  // destroyed without Finish()
  { std::unique_ptr<RecognizeStream> stream = client_.StreamRecognize(); }
  EXPECT_TRUE(client_.ListDatabases().ok());
}

TEST_F(CrossingClientTest, RecognizeStreamAnswersEveryFrameInOrder) {
  CreateDatabase("campus");
  server_.service().set_stream_recognize_from(2);
  cv::Mat frame(24, 32, CV_8UC3, cv::Scalar(0, 128, 255));
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", frame, png));

  std::unique_ptr<RecognizeStream> stream = client_.StreamRecognize();
  for (int i = 0; i < 3; ++i) {
    v1::RecognizeRequest request;
    request.set_database("campus");
    request.mutable_image()->set_data(std::string(png.begin(), png.end()));
    request.mutable_image()->set_stamp(100 + i);
    ASSERT_TRUE(stream->Send(request));
    v1::RecognizeResponse response;
    ASSERT_TRUE(stream->Read(&response));
    EXPECT_EQ(response.frame_index(), i);
    EXPECT_DOUBLE_EQ(response.stamp(), 100 + i);
    EXPECT_EQ(response.recognized(), i >= 2);
  }
  EXPECT_TRUE(stream->WritesDone());
  EXPECT_FALSE(stream->Send(v1::RecognizeRequest()));  // no frames after WritesDone
  v1::RecognizeResponse rest;
  EXPECT_FALSE(stream->Read(&rest));
  EXPECT_TRUE(stream->Finish().ok());
}

TEST_F(CrossingClientTest, RecognizeStreamReportsTheServersError) {
  std::unique_ptr<RecognizeStream> stream = client_.StreamRecognize();
  v1::RecognizeRequest request;
  request.mutable_image()->set_data("not an image");
  stream->Send(request);
  v1::RecognizeResponse response;
  EXPECT_FALSE(stream->Read(&response));
  EXPECT_EQ(stream->Finish(), absl::InvalidArgumentError("frame is not an image"));
}

TEST(DeadlineAfterTest, InfiniteTimeoutMeansNoDeadline) {
  EXPECT_FALSE(DeadlineAfter(absl::InfiniteDuration()).has_value());
  const auto deadline = DeadlineAfter(absl::Seconds(30));
  ASSERT_TRUE(deadline.has_value());
  EXPECT_GT(*deadline, std::chrono::system_clock::now() + std::chrono::seconds(29));
}

}  // namespace
}  // namespace waymark::client
