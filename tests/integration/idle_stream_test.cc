// --stream-idle-seconds on the real server: a stream that sends nothing is ended (and its thread
// and per-robot slot freed); a stream that keeps talking is not.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <memory>
#include <thread>

#include "tests/service/slam_test_world.h"
#include "tests/support/server_process.h"
#include "waymark/v1/crossing.grpc.pb.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark {
namespace {

std::unique_ptr<grpc::ClientContext> Ctx(int seconds) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return ctx;
}

class IdleStreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string dir = testing::MakeTempDir("idle");
    auto server = testing::ServerProcess::Start(testing::ServerBinary(), dir + "/waymark.db",
                                                {"--stream-idle-seconds", "1"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    channel_ = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  }
  std::unique_ptr<testing::ServerProcess> server_;
  std::shared_ptr<grpc::Channel> channel_;
};

TEST_F(IdleStreamTest, ASilentStreamIsEndedByTheServer) {
  v1::CrossingService::Stub stub(channel_);
  // The client's own deadline (60 s) is far beyond the server's idle limit (1 s): if the stream
  // ends, the server ended it.
  auto ctx = Ctx(60);
  auto stream = stub.StreamRecognize(ctx.get());
  v1::RecognizeResponse answer;
  EXPECT_FALSE(stream->Read(&answer));
  const grpc::Status status = stream->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED) << status.error_message();
  EXPECT_NE(server_->Log().find("sent nothing for 1 s"), std::string::npos) << server_->Log();
}

TEST_F(IdleStreamTest, AStreamThatKeepsTalkingStaysOpen) {
  v1::SlamService::Stub stub(channel_);
  v1::Session session;
  ASSERT_TRUE(
      stub.CreateSession(Ctx(30).get(), testing::TestSessionRequest("robot-1"), &session).ok());
  auto ctx = Ctx(60);
  auto stream = stub.StreamSensorData(ctx.get());
  // Every message is a malformed one (NaN stamp) that the server answers with a rejection, so
  // each answer proves the stream is still open. 15 x 0.2 s = 3 s, three idle limits.
  for (int i = 1; i <= 15; ++i) {
    v1::SensorData bad;
    bad.set_session_id(session.session_id());
    bad.set_sequence(i);
    bad.mutable_odometry()->set_stamp(std::numeric_limits<double>::quiet_NaN());
    ASSERT_TRUE(stream->Write(bad)) << "message " << i;
    v1::SlamUpdate update;
    ASSERT_TRUE(stream->Read(&update)) << "message " << i;
    EXPECT_EQ(update.sequence(), static_cast<uint64_t>(i));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  stream->WritesDone();
  v1::SlamUpdate update;
  while (stream->Read(&update)) {
  }
  const grpc::Status status = stream->Finish();
  EXPECT_TRUE(status.ok()) << status.error_message();
}

}  // namespace
}  // namespace waymark
