// The real waymark-server binary, over gRPC on loopback: enrollment, recognition, restart, and
// every bad input of issue 2 with its status code.

#include <signal.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <set>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "tests/support/crossing_test_client.h"
#include "tests/support/raw_stream.h"
#include "tests/support/server_process.h"
#include "tests/support/synthetic_scene.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark {
namespace {

using testing::CropView;
using testing::Ctx;
using testing::EncodeJpeg;
using testing::EncodePng;
using testing::EnrollRequest;
using testing::MakePanorama;
using testing::RecognizeRequest;
using testing::ServerProcess;
using Client = testing::CrossingTestClient;

constexpr int kCrossings = 2;

class CrossingServerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("waymark-it"));
    for (int c = 0; c < kCrossings; ++c) panoramas_[c] = MakePanorama(500 + c);
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override { StartServer(); }
  void TearDown() override {
    if (HasFailure() && server_) std::cerr << "server log:\n" << server_->Log();
  }

  void StartServer(const std::vector<std::string>& args = {}) {
    auto server = ServerProcess::Start(testing::ServerBinary(), *dir_ + "/waymark.db", args);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    client_ = std::make_unique<Client>(server_->address());
  }

  // Sends `requests` over one StreamRecognize call and returns every answer, in order; the call
  // must end OK.
  std::vector<v1::RecognizeResponse> StreamAll(const std::vector<v1::RecognizeRequest>& requests) {
    auto ctx = Ctx();
    auto stream = (*client_)->StreamRecognize(ctx.get());
    for (const v1::RecognizeRequest& q : requests) EXPECT_TRUE(stream->Write(q));
    stream->WritesDone();
    std::vector<v1::RecognizeResponse> responses;
    v1::RecognizeResponse r;
    while (stream->Read(&r)) responses.push_back(r);
    EXPECT_TRUE(stream->Finish().ok());
    return responses;
  }

  // Creates `name` and bulk-enrolls 12 views of each crossing.
  void EnrollAll(const std::string& name) {
    v1::CreateDatabaseRequest create;
    create.set_name(name);
    v1::CrossingDatabase created;
    ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &created).ok());
    auto ctx = Ctx(300);
    v1::BulkEnrollResponse summary;
    auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
    for (int c = 0; c < kCrossings; ++c) {
      for (int k = 0; k < 12; ++k) ASSERT_TRUE(writer->Write(EnrollRequest(name, c, 30.0 * k, panoramas_[c])));
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(summary.views(), 12 * kCrossings);
    EXPECT_EQ(summary.crossings_created(), kCrossings);
    EXPECT_GT(summary.clusters_created(), 0);
    EXPECT_GT(summary.keypoints(), 100 * 12 * kCrossings);
  }

  grpc::StatusCode Code(const grpc::Status& s) { return s.error_code(); }

  static std::string* dir_;
  static cv::Mat panoramas_[kCrossings];
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<Client> client_;
};
std::string* CrossingServerTest::dir_ = nullptr;
cv::Mat CrossingServerTest::panoramas_[kCrossings];

TEST_F(CrossingServerTest, EnrollRecognizeRestartRecognizeTheSame) {
  EnrollAll("restart");
  std::vector<v1::RecognizeResponse> before;
  for (int c = 0; c < kCrossings; ++c) {
    for (double heading : {15.0, 100.0, 270.0}) {
      v1::RecognizeResponse r;
      ASSERT_TRUE(
          (*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("restart", CropView(panoramas_[c], heading)), &r).ok());
      ASSERT_TRUE(r.recognized()) << r.reason();
      EXPECT_EQ(r.crossing(), "crossing-" + std::to_string(c));
      const double error = std::fabs(std::remainder(r.heading_deg() - heading, 360.0));
      EXPECT_LE(error, 30.0);
      EXPECT_GT(r.keypoints(), 50);
      EXPECT_GT(r.timings().extraction_ms(), 0);
      EXPECT_FALSE(r.candidates().empty());
      before.push_back(r);
    }
  }
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("restart");
  v1::DatabaseStats stats_before;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats_before).ok());

  // Graceful stop, then a new process on the same file.
  EXPECT_EQ(server_->Stop(SIGTERM), 0);
  StartServer();
  v1::DatabaseStats stats_after;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats_after).ok());
  EXPECT_EQ(stats_after.database().views(), 12 * kCrossings);
  EXPECT_EQ(stats_after.database().clusters(), stats_before.database().clusters());
  EXPECT_EQ(stats_after.keypoints(), stats_before.keypoints());
  size_t i = 0;
  for (int c = 0; c < kCrossings; ++c) {
    for (double heading : {15.0, 100.0, 270.0}) {
      v1::RecognizeResponse r;
      ASSERT_TRUE(
          (*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("restart", CropView(panoramas_[c], heading)), &r).ok());
      const v1::RecognizeResponse& b = before[i++];
      EXPECT_EQ(r.recognized(), b.recognized());
      EXPECT_EQ(r.view_id(), b.view_id());
      EXPECT_EQ(r.crossing(), b.crossing());
      EXPECT_DOUBLE_EQ(r.decision(), b.decision());
      ASSERT_EQ(r.candidates_size(), b.candidates_size());
      for (int k = 0; k < r.candidates_size(); ++k) {
        EXPECT_EQ(r.candidates(k).view_id(), b.candidates(k).view_id());
        EXPECT_EQ(r.candidates(k).matches(), b.candidates(k).matches());
      }
    }
  }
}

TEST_F(CrossingServerTest, DatabaseLifecycleAndNames) {
  v1::CreateDatabaseRequest create;
  create.set_name("lifecycle");
  v1::CrossingDatabase db;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &db).ok());
  EXPECT_EQ(db.params().work_width(), 320);
  EXPECT_EQ(db.params().recognition().n0(), 5);
  EXPECT_DOUBLE_EQ(db.params().recognition().ratio(), 0.32);
  EXPECT_EQ(Code((*client_)->CreateDatabase(Ctx().get(), create, &db)), grpc::StatusCode::ALREADY_EXISTS);
  create.set_name("bad/name");
  EXPECT_EQ(Code((*client_)->CreateDatabase(Ctx().get(), create, &db)), grpc::StatusCode::INVALID_ARGUMENT);

  v1::AddCrossingRequest add;
  add.set_database("lifecycle");
  add.set_name("main-and-5th");
  v1::Crossing crossing;
  ASSERT_TRUE((*client_)->AddCrossing(Ctx().get(), add, &crossing).ok());
  EXPECT_EQ(Code((*client_)->AddCrossing(Ctx().get(), add, &crossing)), grpc::StatusCode::ALREADY_EXISTS);
  add.set_database("nope");
  EXPECT_EQ(Code((*client_)->AddCrossing(Ctx().get(), add, &crossing)), grpc::StatusCode::NOT_FOUND);

  v1::ListDatabasesResponse list;
  ASSERT_TRUE((*client_)->ListDatabases(Ctx().get(), {}, &list).ok());
  bool found = false;
  for (const auto& d : list.databases()) found |= d.name() == "lifecycle" && d.crossings() == 1;
  EXPECT_TRUE(found);

  v1::DeleteCrossingRequest del_crossing;
  del_crossing.set_database("lifecycle");
  del_crossing.set_name("nope");
  v1::DeleteCrossingResponse del_crossing_response;
  EXPECT_EQ(Code((*client_)->DeleteCrossing(Ctx().get(), del_crossing, &del_crossing_response)),
            grpc::StatusCode::NOT_FOUND);

  v1::DeleteDatabaseRequest del;
  del.set_name("lifecycle");
  v1::DeleteDatabaseResponse deleted;
  ASSERT_TRUE((*client_)->DeleteDatabase(Ctx().get(), del, &deleted).ok());
  EXPECT_EQ(Code((*client_)->DeleteDatabase(Ctx().get(), del, &deleted)), grpc::StatusCode::NOT_FOUND);
}

TEST_F(CrossingServerTest, BadParametersAreInvalidArgument) {
  v1::CreateDatabaseRequest create;
  create.set_name("params");
  create.mutable_params()->mutable_recognition()->set_ratio(1.5);
  v1::CrossingDatabase db;
  grpc::Status s = (*client_)->CreateDatabase(Ctx().get(), create, &db);
  EXPECT_EQ(Code(s), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("ratio"), std::string::npos) << s.error_message();
  create.mutable_params()->mutable_recognition()->set_ratio(0.5);
  create.mutable_params()->mutable_recognition()->set_alpha(0.7);
  s = (*client_)->CreateDatabase(Ctx().get(), create, &db);
  EXPECT_EQ(Code(s), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("alpha"), std::string::npos) << s.error_message();
  create.mutable_params()->clear_recognition();
  create.mutable_params()->set_work_width(5);
  EXPECT_EQ(Code((*client_)->CreateDatabase(Ctx().get(), create, &db)), grpc::StatusCode::INVALID_ARGUMENT);

  // Per-request overrides are validated too, and the database is left usable.
  EnrollAll("params-ok");
  v1::RecognizeRequest q = RecognizeRequest("params-ok", CropView(panoramas_[0], 0));
  q.mutable_params()->set_ratio(0.0);
  v1::RecognizeResponse r;
  EXPECT_EQ(Code((*client_)->RecognizeCrossing(Ctx().get(), q, &r)), grpc::StatusCode::INVALID_ARGUMENT);
  q.mutable_params()->set_ratio(0.32);
  q.mutable_params()->set_alpha(0.2);  // beta stays 0.5
  EXPECT_EQ(Code((*client_)->RecognizeCrossing(Ctx().get(), q, &r)), grpc::StatusCode::INVALID_ARGUMENT);
  q.mutable_params()->set_beta(0.8);
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), q, &r).ok());
  EXPECT_TRUE(r.recognized());
  q.mutable_params()->Clear();
  q.mutable_params()->set_mode(v1::RECOGNITION_MODE_VERIFIED);
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), q, &r).ok());
  EXPECT_EQ(r.mode(), v1::RECOGNITION_MODE_VERIFIED);
  EXPECT_TRUE(r.recognized()) << r.reason();
}

TEST_F(CrossingServerTest, BadImagesAndHeadingsAreRejectedAndNothingIsStored) {
  EnrollAll("bad-input");
  const cv::Mat good = CropView(panoramas_[0], 45);
  struct Case {
    std::string name;
    std::string bytes;
    double heading;
  };
  std::string truncated = EncodeJpeg(good);
  truncated.resize(truncated.size() / 3);
  const std::vector<Case> cases = {
      {"empty", "", 10},
      {"garbage", "this is not an image", 10},
      {"truncated jpeg", truncated, 10},
      {"1x1", EncodePng(cv::Mat(1, 1, CV_8UC3, cv::Scalar(1, 2, 3))), 10},
      {"no texture", EncodePng(cv::Mat(240, 320, CV_8UC3, cv::Scalar(20, 90, 160))), 10},
      {"heading 360", EncodeJpeg(good), 360},
      {"heading -1", EncodeJpeg(good), -1},
      {"heading NaN", EncodeJpeg(good), std::numeric_limits<double>::quiet_NaN()},
  };
  for (const Case& c : cases) {
    v1::EnrollViewRequest r;
    r.set_database("bad-input");
    r.set_crossing("crossing-0");
    r.set_heading_deg(c.heading);
    r.mutable_image()->set_data(c.bytes);
    v1::EnrollViewResponse response;
    const grpc::Status s = (*client_)->EnrollView(Ctx().get(), r, &response);
    EXPECT_EQ(Code(s), grpc::StatusCode::INVALID_ARGUMENT) << c.name << ": " << s.error_message();
    EXPECT_FALSE(s.error_message().empty()) << c.name;
  }
  // Unknown crossing without create_crossing; unknown database.
  v1::EnrollViewRequest r = EnrollRequest("bad-input", 9, 0, panoramas_[0]);
  r.set_create_crossing(false);
  v1::EnrollViewResponse response;
  EXPECT_EQ(Code((*client_)->EnrollView(Ctx().get(), r, &response)), grpc::StatusCode::NOT_FOUND);
  r.set_database("no-such-db");
  EXPECT_EQ(Code((*client_)->EnrollView(Ctx().get(), r, &response)), grpc::StatusCode::NOT_FOUND);

  // Nothing of the above was stored.
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("bad-input");
  v1::DatabaseStats stats;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats).ok());
  EXPECT_EQ(stats.database().views(), 12 * kCrossings);
  EXPECT_EQ(stats.database().crossings(), kCrossings);

  // Recognition: corrupt image, unknown database, and the server still answers afterwards.
  v1::RecognizeRequest q;
  q.set_database("bad-input");
  q.mutable_image()->set_data("garbage");
  v1::RecognizeResponse rr;
  EXPECT_EQ(Code((*client_)->RecognizeCrossing(Ctx().get(), q, &rr)), grpc::StatusCode::INVALID_ARGUMENT);
  q = RecognizeRequest("no-such-db", good);
  EXPECT_EQ(Code((*client_)->RecognizeCrossing(Ctx().get(), q, &rr)), grpc::StatusCode::NOT_FOUND);
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("bad-input", good), &rr).ok());
  EXPECT_TRUE(rr.recognized());
}

TEST_F(CrossingServerTest, BulkEnrollSkipsInvalidViewsOnlyWhenAsked) {
  v1::CreateDatabaseRequest create;
  create.set_name("skip");
  v1::CrossingDatabase db;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &db).ok());
  for (bool skip : {true, false}) {
    auto ctx = Ctx();
    v1::BulkEnrollResponse summary;
    auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
    for (int k = 0; k < 4; ++k) {
      // Each stream its own images: the same image twice would be a duplicate, not a new view.
      v1::EnrollViewRequest r =
          EnrollRequest("skip", skip ? 0 : 1, 30.0 * k, panoramas_[skip ? 0 : 1]);
      if (k == 2) {
        r.mutable_image()->set_data(EncodePng(cv::Mat(240, 320, CV_8UC3, cv::Scalar(9, 9, 200))));
      }
      r.set_skip_invalid(skip);
      writer->Write(r);
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    if (skip) {
      ASSERT_TRUE(status.ok()) << status.error_message();
      EXPECT_EQ(summary.views(), 3);
      ASSERT_EQ(summary.skipped_size(), 1);
      EXPECT_EQ(summary.skipped(0).index(), 2);
      EXPECT_DOUBLE_EQ(summary.skipped(0).heading_deg(), 60.0);
      EXPECT_NE(summary.skipped(0).reason().find("keypoints"), std::string::npos);
    } else {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
      EXPECT_NE(status.error_message().find("heading 60"), std::string::npos)
          << status.error_message();
    }
  }
  // 3 views from the skipping stream, 2 from the strict one (stopped at its third view).
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("skip");
  v1::DatabaseStats stats;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats).ok());
  EXPECT_EQ(stats.database().views(), 5);
}

// Issue 35: the answers quote client text as valid UTF-8 and bounded. A position cut at 64 bytes
// inside a character made Python's protobuf refuse the whole BulkEnroll answer, and a skipped
// view echoed a 1 MB position. This client's C++ protobuf is as strict as Python's about UTF-8 in
// proto3 strings: an answer it parses is one every client can.
TEST_F(CrossingServerTest, BulkEnrollSkipsQuoteClientTextValidAndBounded) {
  v1::CreateDatabaseRequest create;
  create.set_name("quotes");
  v1::CrossingDatabase db;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &db).ok());
  std::string cut_inside = "a";  // byte 64 is inside the 32nd "é"
  for (int i = 0; i < 40; ++i) cut_inside += "\u00e9";
  const std::string megabyte(1 << 20, 'p');
  auto ctx = Ctx();
  v1::BulkEnrollResponse summary;
  auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
  for (const std::string& position : {cut_inside, megabyte}) {
    v1::EnrollViewRequest r = EnrollRequest("quotes", 0, 30.0, panoramas_[0]);
    r.set_position(position);
    r.set_skip_invalid(true);
    ASSERT_TRUE(writer->Write(r));
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  ASSERT_TRUE(status.ok()) << status.error_message().substr(0, 300);
  ASSERT_EQ(summary.skipped_size(), 2);
  EXPECT_EQ(summary.skipped(0).position(), cut_inside);  // a value under the bound: whole
  EXPECT_NE(summary.skipped(0).reason().find("position \"" + cut_inside + "\""),
            std::string::npos)
      << summary.skipped(0).reason();
  EXPECT_EQ(summary.skipped(1).position(), std::string(128, 'p') + "...");
  EXPECT_LT(summary.skipped(1).reason().size(), 300u) << summary.skipped(1).reason().size();
  EXPECT_LT(summary.ByteSizeLong(), 2000u);
}

// A unary request that does not parse is the client's error: INVALID_ARGUMENT naming the method
// (gRPC's generated handler says INTERNAL, and so does its health service's Watch), and a valid
// call goes on being served.
TEST_F(CrossingServerTest, AnUnparsableUnaryRequestIsInvalidArgument) {
  const auto channel =
      grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  for (const std::string method : {"/waymark.v1.CrossingService/ListDatabases",
                                   "/waymark.v1.SlamService/GetMap",
                                   "/waymark.v1.TokenService/ListTokens",
                                   "/grpc.health.v1.Health/Check",
                                   "/grpc.health.v1.Health/Watch"}) {
    SCOPED_TRACE(method);
    testing::RawStream call(channel, method);
    ASSERT_TRUE(call.WriteBytes(testing::UnparsableMessage()));
    std::vector<v1::ListDatabasesResponse> answers;
    const grpc::Status status = call.Finish(&answers);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find("parse"), std::string::npos) << status.error_message();
  }
  v1::ListDatabasesResponse list;
  EXPECT_TRUE((*client_)->ListDatabases(Ctx().get(), v1::ListDatabasesRequest(), &list).ok());

  // A name that is not UTF-8 does not parse either, and protobuf's complaint goes to the log at
  // debug level, not to stderr as an ERROR line per request (15,827 in the campaign).
  testing::RawStream call(channel, "/waymark.v1.CrossingService/CreateDatabase");
  ASSERT_TRUE(call.WriteBytes(std::string("\x0a\x02\xff\xfe", 4)));
  std::vector<v1::CrossingDatabase> answers;
  EXPECT_EQ(call.Finish(&answers).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(server_->Log().find("libprotobuf ERROR"), std::string::npos) << server_->Log();
}

// Issue 21: a message that does not parse in the middle of a client stream ends the stream with
// INVALID_ARGUMENT naming it, after the messages before it were answered. It used to end the
// stream with OK, exactly like the client's own end, and the messages after it were lost.
TEST_F(CrossingServerTest, AnUnparsableMessageEndsAClientStreamWithInvalidArgument) {
  EnrollAll("unparsable");
  const auto channel =
      grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  {
    testing::RawStream stream(channel, "/waymark.v1.CrossingService/StreamRecognize");
    const cv::Mat query = CropView(panoramas_[0], 30.0);
    for (int i = 0; i < 5; ++i) ASSERT_TRUE(stream.Write(RecognizeRequest("unparsable", query)));
    ASSERT_TRUE(stream.WriteBytes(testing::UnparsableMessage()));
    for (int i = 0; i < 5; ++i) stream.Write(RecognizeRequest("unparsable", query));
    std::vector<v1::RecognizeResponse> answers;
    const grpc::Status status = stream.Finish(&answers);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find("message 6 of the stream"), std::string::npos)
        << status.error_message();
    EXPECT_EQ(answers.size(), 5u);
  }
  for (const std::string method : {"BulkEnroll", "StreamEnroll"}) {
    SCOPED_TRACE(method);
    v1::GetDatabaseStatsRequest stats_request;
    stats_request.set_name("unparsable");
    v1::DatabaseStats before;
    ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &before).ok());
    testing::RawStream stream(channel, "/waymark.v1.CrossingService/" + method, 300);
    const double offset = method == "BulkEnroll" ? 7.0 : 11.0;  // new images for each stream
    for (int k = 0; k < 3; ++k) {
      v1::EnrollViewRequest view = EnrollRequest("unparsable", 1, offset + 30.0 * k, panoramas_[1]);
      view.set_skip_invalid(true);
      ASSERT_TRUE(stream.Write(view));
    }
    ASSERT_TRUE(stream.WriteBytes(testing::UnparsableMessage()));
    for (int k = 3; k < 6; ++k) {
      v1::EnrollViewRequest view = EnrollRequest("unparsable", 1, offset + 30.0 * k, panoramas_[1]);
      view.set_skip_invalid(true);
      stream.Write(view);
    }
    std::vector<v1::EnrollViewResponse> answers;  // StreamEnroll: one per view taken
    const grpc::Status status = stream.Finish(&answers);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find("message 4 of the stream"), std::string::npos)
        << status.error_message();
    if (method == "StreamEnroll") EXPECT_EQ(answers.size(), 3u);
    v1::DatabaseStats after;
    ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &after).ok());
    EXPECT_EQ(after.database().views(), before.database().views() + 3);  // those before it
  }
}

// Issue 15: enrolling the same images again (a re-run of `waymark enroll`) stores nothing, over
// every enrollment RPC, and still after a restart (the hashes are stored with the views).
TEST_F(CrossingServerTest, TheSameImagesAgainAreDuplicatesOverEveryEnrollRpc) {
  EnrollAll("again");
  {
    auto ctx = Ctx(300);
    v1::BulkEnrollResponse summary;
    auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
    for (int c = 0; c < kCrossings; ++c) {
      for (int k = 0; k < 12; ++k) {
        ASSERT_TRUE(writer->Write(EnrollRequest("again", c, 30.0 * k, panoramas_[c])));
      }
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(summary.views(), 0);
    EXPECT_EQ(summary.duplicates(), 12 * kCrossings);
    EXPECT_EQ(summary.crossings_created(), 0);
  }

  // StreamEnroll answers each view: two stored already, one new, one invalid (skipped).
  std::vector<v1::EnrollViewRequest> requests = {
      EnrollRequest("again", 0, 0, panoramas_[0]), EnrollRequest("again", 0, 30, panoramas_[0]),
      EnrollRequest("again", 0, 15, panoramas_[0]),
      EnrollRequest("again", 0, 45, panoramas_[0])};
  requests[3].mutable_image()->set_data("not an image");
  std::vector<v1::EnrollViewResponse> answers;
  {
    auto ctx = Ctx(300);
    auto stream = (*client_)->StreamEnroll(ctx.get());
    for (v1::EnrollViewRequest& request : requests) {
      request.set_skip_invalid(true);
      ASSERT_TRUE(stream->Write(request));
    }
    stream->WritesDone();
    for (v1::EnrollViewResponse answer; stream->Read(&answer);) answers.push_back(answer);
    const grpc::Status status = stream->Finish();
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  ASSERT_EQ(answers.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(answers[i].index(), i);
  EXPECT_EQ(answers[0].outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
  EXPECT_EQ(answers[0].crossing(), "crossing-0");
  EXPECT_DOUBLE_EQ(answers[0].heading_deg(), 0);
  EXPECT_GT(answers[0].view_id(), 0);
  EXPECT_EQ(answers[1].outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
  EXPECT_EQ(answers[2].outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_FALSE(answers[2].crossing_created());
  EXPECT_GT(answers[2].keypoints(), 100);
  EXPECT_EQ(answers[3].outcome(), v1::ENROLL_OUTCOME_INVALID);
  EXPECT_EQ(answers[3].error_code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
  EXPECT_FALSE(answers[3].error_message().empty());

  // The same image under another crossing name is the same image: a duplicate naming where it is.
  v1::EnrollViewRequest elsewhere = requests[2];
  elsewhere.set_crossing("somewhere-else");
  v1::EnrollViewResponse answer;
  ASSERT_TRUE((*client_)->EnrollView(Ctx().get(), elsewhere, &answer).ok());
  EXPECT_EQ(answer.outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
  EXPECT_EQ(answer.view_id(), answers[2].view_id());
  EXPECT_EQ(answer.crossing(), "crossing-0");
  EXPECT_DOUBLE_EQ(answer.heading_deg(), 15);

  server_->Stop(SIGTERM);
  StartServer();
  ASSERT_TRUE((*client_)->EnrollView(Ctx().get(), requests[0], &answer).ok());
  EXPECT_EQ(answer.outcome(), v1::ENROLL_OUTCOME_DUPLICATE) << "hashes survive a restart";
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("again");
  v1::DatabaseStats stats;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats).ok());
  EXPECT_EQ(stats.database().views(), 12 * kCrossings + 1);
  EXPECT_EQ(stats.database().crossings(), kCrossings);
}

// `replace`: a new image takes the place of the view at its crossing and heading, an image filed
// under another crossing moves, and the clusters stay what a rebuild gives.
TEST_F(CrossingServerTest, ReplaceSwapsViewsAndKeepsTheClustersOfARebuild) {
  EnrollAll("replace");
  auto stats = [&] {
    v1::GetDatabaseStatsRequest request;
    request.set_name("replace");
    v1::DatabaseStats out;
    EXPECT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), request, &out).ok());
    return out;
  };
  // A re-shot view of crossing-0 at 30 degrees (taken 5 degrees further round).
  v1::EnrollViewRequest reshot = EnrollRequest("replace", 0, 30, panoramas_[0]);
  reshot.mutable_image()->set_data(EncodeJpeg(CropView(panoramas_[0], 35)));
  reshot.set_replace(true);
  v1::EnrollViewResponse answer;
  ASSERT_TRUE((*client_)->EnrollView(Ctx().get(), reshot, &answer).ok());
  EXPECT_EQ(answer.outcome(), v1::ENROLL_OUTCOME_STORED);
  ASSERT_EQ(answer.replaced_view_ids_size(), 1);
  const int64_t reshot_id = answer.view_id();
  // Again: it is already there, nothing to replace.
  ASSERT_TRUE((*client_)->EnrollView(Ctx().get(), reshot, &answer).ok());
  EXPECT_EQ(answer.outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
  EXPECT_EQ(answer.view_id(), reshot_id);

  // crossing-1's view at 60 degrees filed under a new crossing: it moves there.
  v1::EnrollViewRequest moved = EnrollRequest("replace", 1, 60, panoramas_[1]);
  moved.set_crossing("crossing-1-bis");
  moved.set_replace(true);
  ASSERT_TRUE((*client_)->EnrollView(Ctx().get(), moved, &answer).ok());
  EXPECT_EQ(answer.outcome(), v1::ENROLL_OUTCOME_STORED);
  EXPECT_TRUE(answer.crossing_created());
  EXPECT_EQ(answer.replaced_view_ids_size(), 1);

  const v1::DatabaseStats after = stats();
  EXPECT_EQ(after.database().views(), 12 * kCrossings);
  std::map<std::string, int> views_per_crossing;
  for (const v1::Crossing& c : after.crossing_list()) views_per_crossing[c.name()] = c.views();
  EXPECT_EQ(views_per_crossing["crossing-0"], 12);
  EXPECT_EQ(views_per_crossing["crossing-1"], 11);
  EXPECT_EQ(views_per_crossing["crossing-1-bis"], 1);
  int64_t keypoints = 0;
  std::set<std::pair<int64_t, int>> clusters;
  for (const v1::ClusterInfo& c : after.clusters()) clusters.insert({c.center_view_id(), c.members()});
  keypoints = after.keypoints();
  int members = 0;
  for (const auto& [centre, count] : clusters) members += count;
  EXPECT_EQ(members, after.database().views());

  v1::RebuildClustersRequest rebuild;
  rebuild.set_database("replace");
  v1::RebuildClustersResponse rebuilt;
  ASSERT_TRUE((*client_)->RebuildClusters(Ctx().get(), rebuild, &rebuilt).ok());
  std::set<std::pair<int64_t, int>> rebuilt_clusters;
  const v1::DatabaseStats after_rebuild = stats();
  for (const v1::ClusterInfo& c : after_rebuild.clusters()) {
    rebuilt_clusters.insert({c.center_view_id(), c.members()});
  }
  EXPECT_EQ(rebuilt_clusters, clusters);
  EXPECT_EQ(after_rebuild.keypoints(), keypoints);

  v1::RecognizeResponse r;
  ASSERT_TRUE((*client_)
                  ->RecognizeCrossing(Ctx().get(),
                                      RecognizeRequest("replace", CropView(panoramas_[0], 36)), &r)
                  .ok());
  EXPECT_TRUE(r.recognized()) << r.reason();
  EXPECT_EQ(r.view_id(), reshot_id);

  // The same after a restart: memory and disk agreed.
  server_->Stop(SIGTERM);
  StartServer();
  const v1::DatabaseStats restarted = stats();
  EXPECT_EQ(restarted.database().views(), after.database().views());
  EXPECT_EQ(restarted.keypoints(), keypoints);
}

TEST_F(CrossingServerTest, EmptyDatabaseAndNoTextureQueries) {
  v1::CreateDatabaseRequest create;
  create.set_name("empty");
  v1::CrossingDatabase db;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &db).ok());
  v1::RecognizeResponse r;
  const grpc::Status s =
      (*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("empty", CropView(panoramas_[0], 0)), &r);
  EXPECT_EQ(Code(s), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(s.error_message().find("enroll"), std::string::npos);

  EnrollAll("texture");
  const cv::Mat flat(240, 320, CV_8UC3, cv::Scalar(20, 90, 160));
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("texture", flat), &r).ok());
  EXPECT_FALSE(r.recognized());
  EXPECT_FALSE(r.reason().empty());
  // An unknown place is a normal "not recognized" answer.
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("texture", CropView(MakePanorama(4242), 10)), &r).ok());
  EXPECT_FALSE(r.recognized()) << r.crossing();
}

TEST_F(CrossingServerTest, HugeImagesAreResizedAndOversizedMessagesRefused) {
  EnrollAll("sizes");
  // A 4000x3000 photo of a known view: resized to the working resolution, recognized.
  cv::Mat big;
  cv::resize(CropView(panoramas_[1], 200), big, cv::Size(4000, 3000));
  v1::RecognizeResponse r;
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("sizes", big), &r).ok());
  EXPECT_TRUE(r.recognized());
  EXPECT_EQ(r.crossing(), "crossing-1");

  // Over the limit (server started with 1 MiB): RESOURCE_EXHAUSTED, and the server lives on.
  server_->Stop(SIGTERM);
  StartServer({"--max-message-mb", "1"});
  v1::RecognizeRequest q;
  q.set_database("sizes");
  q.mutable_image()->set_data(std::string(2 << 20, 'x'));
  EXPECT_EQ(Code((*client_)->RecognizeCrossing(Ctx().get(), q, &r)), grpc::StatusCode::RESOURCE_EXHAUSTED);
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("sizes", CropView(panoramas_[1], 200)), &r).ok());
  EXPECT_TRUE(r.recognized());
}

TEST_F(CrossingServerTest, StreamRecognizeAnswersEveryFrameAndSurvivesABadOne) {
  EnrollAll("stream");
  const std::vector<std::string> frames = {
      EncodeJpeg(CropView(MakePanorama(777), 0)),  // unknown place
      "corrupt frame",
      EncodeJpeg(CropView(panoramas_[0], 95)),
      EncodeJpeg(CropView(panoramas_[1], 300)),
  };
  std::vector<v1::RecognizeRequest> requests;
  for (size_t i = 0; i < frames.size(); ++i) {
    v1::RecognizeRequest& q = requests.emplace_back();
    q.set_database("stream");
    q.mutable_image()->set_data(frames[i]);
    q.mutable_image()->set_stamp(100.0 + i);
  }
  const std::vector<v1::RecognizeResponse> responses = StreamAll(requests);
  ASSERT_EQ(responses.size(), frames.size());
  for (size_t i = 0; i < responses.size(); ++i) {
    EXPECT_EQ(responses[i].frame_index(), static_cast<int64_t>(i));
    EXPECT_DOUBLE_EQ(responses[i].stamp(), 100.0 + i);
  }
  EXPECT_FALSE(responses[0].recognized());
  EXPECT_EQ(responses[0].error_code(), 0);
  EXPECT_EQ(responses[1].error_code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
  EXPECT_TRUE(responses[2].recognized());
  EXPECT_EQ(responses[2].crossing(), "crossing-0");
  EXPECT_TRUE(responses[3].recognized());
  EXPECT_EQ(responses[3].crossing(), "crossing-1");
}

// Issue 21 campaign: a refusal quoting a client's 8 MiB name went out in the status message and
// the client refused the headers (RESOURCE_EXHAUSTED, connection closed); a bad frame's NaN stamp
// was echoed. The code now arrives, with a message cut to 1 KiB, and no NaN leaves the server.
TEST_F(CrossingServerTest, HugeNamesInRefusalsAndNonFiniteStampsDoNotReachTheClientAsSuch) {
  v1::CreateDatabaseRequest create;
  create.set_name(std::string(8 << 20, 'n'));
  v1::CrossingDatabase db;
  const grpc::Status refused = (*client_)->CreateDatabase(Ctx().get(), create, &db);
  EXPECT_EQ(Code(refused), grpc::StatusCode::INVALID_ARGUMENT) << refused.error_message().size();
  EXPECT_LT(refused.error_message().size(), 1200u);
  // The name is quoted by its first 64 characters (server/common/quote.h), not echoed whole.
  EXPECT_NE(refused.error_message().find("\"" + std::string(64, 'n') + "...\""),
            std::string::npos)
      << refused.error_message().substr(0, 200);

  EnrollAll("nan-stamps");
  v1::RecognizeRequest bad;
  bad.set_database("nan-stamps");
  bad.mutable_image()->set_data("corrupt frame");
  bad.mutable_image()->set_stamp(std::nan(""));
  // A good image with a stamp that is no time: refused, naming the stamp (it was recognized and
  // the NaN echoed, 18 times in the second campaign).
  v1::RecognizeRequest good_image = bad;
  good_image.mutable_image()->set_data(EncodeJpeg(CropView(panoramas_[0], 40.0)));
  v1::RecognizeRequest infinite = good_image;
  infinite.mutable_image()->set_stamp(-std::numeric_limits<double>::infinity());
  const std::vector<v1::RecognizeResponse> responses = StreamAll({bad, good_image, infinite});
  ASSERT_EQ(responses.size(), 3u);
  for (const v1::RecognizeResponse& response : responses) {
    EXPECT_EQ(response.error_code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
    EXPECT_TRUE(std::isfinite(response.stamp()));
  }
  EXPECT_NE(responses[1].error_message().find("stamp"), std::string::npos)
      << responses[1].error_message();
  v1::RecognizeResponse unary;
  const grpc::Status status = (*client_)->RecognizeCrossing(Ctx().get(), good_image, &unary);
  EXPECT_EQ(Code(status), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("stamp"), std::string::npos) << status.error_message();
}

// Retrieval mode over a stream: the answer is the belief over the frames so far; one frame
// does not decide, agreeing frames do, and a robot that moves on is followed.
TEST_F(CrossingServerTest, StreamRecognizeInRetrievalModeDecidesOnEvidenceOverFrames) {
  EnrollAll("evidence");
  std::vector<std::string> frames;
  for (double h : {40.0, 47.0, 54.0, 61.0}) frames.push_back(EncodeJpeg(CropView(panoramas_[0], h)));
  for (double h : {200.0, 207.0, 214.0, 221.0, 228.0}) {
    frames.push_back(EncodeJpeg(CropView(panoramas_[1], h)));
  }
  std::vector<v1::RecognizeRequest> requests;
  for (const std::string& f : frames) {
    v1::RecognizeRequest& q = requests.emplace_back();
    q.set_database("evidence");
    q.mutable_image()->set_data(f);
    q.mutable_params()->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  }
  const std::vector<v1::RecognizeResponse> responses = StreamAll(requests);
  ASSERT_EQ(responses.size(), frames.size());
  for (const auto& answer : responses) {
    EXPECT_EQ(answer.mode(), v1::RECOGNITION_MODE_RETRIEVAL);
    EXPECT_TRUE(answer.has_evidence());
  }
  // Frame 0: the frame alone is sure, the belief not yet.
  EXPECT_TRUE(responses[0].evidence().frame_recognized());
  EXPECT_FALSE(responses[0].recognized());
  EXPECT_EQ(responses[0].evidence().crossing(), "crossing-0");
  EXPECT_LT(responses[0].evidence().posterior(), 0.95);
  // From the second agreeing frame on: recognized, with this frame's best view of the crossing.
  for (int i = 1; i < 4; ++i) {
    EXPECT_TRUE(responses[i].recognized()) << i;
    EXPECT_EQ(responses[i].crossing(), "crossing-0") << i;
    EXPECT_GT(responses[i].view_id(), 0) << i;
    EXPECT_LT(responses[i].log10_nfa(), 0) << i;
  }
  EXPECT_EQ(responses[3].evidence().frames(), 4);
  // The robot moved on: crossing-1 within three frames, and not on its first.
  EXPECT_NE(responses[4].crossing(), "crossing-1");
  bool followed = false;
  for (size_t i = 5; i < 7; ++i) followed = followed || responses[i].crossing() == "crossing-1";
  EXPECT_TRUE(followed);
  EXPECT_EQ(responses.back().crossing(), "crossing-1");
  EXPECT_TRUE(responses.back().recognized());
}

TEST_F(CrossingServerTest, DeleteCrossingReclustersAndRebuildKeepsRecognition) {
  EnrollAll("edit");
  v1::DeleteCrossingRequest del;
  del.set_database("edit");
  del.set_name("crossing-0");
  v1::DeleteCrossingResponse deleted;
  ASSERT_TRUE((*client_)->DeleteCrossing(Ctx().get(), del, &deleted).ok());
  EXPECT_EQ(deleted.views_deleted(), 12);
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database("edit");
  rebuild.set_cluster_threshold(8);
  v1::RebuildClustersResponse rebuilt;
  ASSERT_TRUE((*client_)->RebuildClusters(Ctx().get(), rebuild, &rebuilt).ok());
  EXPECT_EQ(rebuilt.views(), 12);
  rebuild.set_cluster_threshold(0);
  EXPECT_EQ(Code((*client_)->RebuildClusters(Ctx().get(), rebuild, &rebuilt)), grpc::StatusCode::INVALID_ARGUMENT);
  v1::RecognizeResponse r;
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("edit", CropView(panoramas_[1], 150)), &r).ok());
  EXPECT_TRUE(r.recognized());
  EXPECT_EQ(r.crossing(), "crossing-1");
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), RecognizeRequest("edit", CropView(panoramas_[0], 150)), &r).ok());
  EXPECT_FALSE(r.recognized()) << "deleted crossing still recognized";
  // The new threshold survives a restart.
  server_->Stop(SIGTERM);
  StartServer();
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("edit");
  v1::DatabaseStats stats;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats).ok());
  EXPECT_EQ(stats.database().params().cluster_threshold(), 8);
  EXPECT_EQ(stats.database().clusters(), rebuilt.clusters());
}

TEST_F(CrossingServerTest, ShutdownLetsAStreamInFlightFinishAndKeepsEveryView) {
  v1::CreateDatabaseRequest create;
  create.set_name("inflight");
  v1::CrossingDatabase db;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &db).ok());
  auto ctx = Ctx();
  v1::BulkEnrollResponse summary;
  auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
  for (int k = 0; k < 6; ++k) ASSERT_TRUE(writer->Write(EnrollRequest("inflight", 0, 30.0 * k, panoramas_[0])));
  // SIGTERM while the stream is open: the server stops taking new calls but this one goes on.
  kill(server_->pid(), SIGTERM);
  for (int k = 6; k < 12; ++k) ASSERT_TRUE(writer->Write(EnrollRequest("inflight", 0, 30.0 * k, panoramas_[0])));
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(summary.views(), 12);
  EXPECT_EQ(server_->Stop(SIGTERM), 0);  // already exiting; reaps it
  StartServer();
  v1::GetDatabaseStatsRequest stats_request;
  stats_request.set_name("inflight");
  v1::DatabaseStats stats;
  ASSERT_TRUE((*client_)->GetDatabaseStats(Ctx().get(), stats_request, &stats).ok());
  EXPECT_EQ(stats.database().views(), 12);
}

// What grpcurl does first: ServerReflectionInfo with list_services (field 7, "") must name the
// crossing service. A bidirectional generic call, driven on a completion queue.
TEST_F(CrossingServerTest, ServerReflectionListsTheCrossingService) {
  grpc::GenericStub generic(client_->channel());
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::CompletionQueue cq;
  auto call = generic.PrepareCall(&ctx, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
                                  &cq);
  void* tag;
  bool ok = false;
  auto step = [&](intptr_t expected) {
    EXPECT_TRUE(cq.Next(&tag, &ok));
    EXPECT_EQ(reinterpret_cast<intptr_t>(tag), expected);
    return ok;
  };
  call->StartCall(reinterpret_cast<void*>(1));
  ASSERT_TRUE(step(1));
  grpc::Slice list_services(std::string("\x3a\x00", 2));
  grpc::ByteBuffer request(&list_services, 1);
  call->Write(request, reinterpret_cast<void*>(2));
  ASSERT_TRUE(step(2));
  grpc::ByteBuffer response;
  call->Read(&response, reinterpret_cast<void*>(3));
  ASSERT_TRUE(step(3));
  call->WritesDone(reinterpret_cast<void*>(4));
  step(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  step(5);
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(response.Dump(&slices).ok());
  std::string bytes;
  for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  EXPECT_NE(bytes.find("waymark.v1.CrossingService"), std::string::npos);
  EXPECT_NE(bytes.find("grpc.health.v1.Health"), std::string::npos);
}

TEST_F(CrossingServerTest, HealthServiceAndGracefulShutdown) {
  // grpc.health.v1.Health/Check with an empty request; the response's status field 1 = SERVING
  // is encoded as the two bytes 08 01.
  grpc::GenericStub generic(client_->channel());
  grpc::ByteBuffer request, response;
  {
    grpc::Slice empty("");
    request = grpc::ByteBuffer(&empty, 1);
  }
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  std::mutex mu;
  std::condition_variable cv;
  bool done = false;
  grpc::Status status;
  generic.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                    [&](grpc::Status s) {
                      std::lock_guard<std::mutex> lock(mu);
                      status = s;
                      done = true;
                      cv.notify_one();
                    });
  std::unique_lock<std::mutex> lock(mu);
  cv.wait(lock, [&] { return done; });
  ASSERT_TRUE(status.ok()) << status.error_message();
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(response.Dump(&slices).ok());
  std::string bytes;
  for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  EXPECT_EQ(bytes, std::string("\x08\x01", 2));
  EXPECT_EQ(server_->Stop(SIGINT), 0);
}

}  // namespace
}  // namespace waymark
