// The call interceptor on an in-process gRPC server with a scripted CrossingService: request ids,
// per-method/per-code counters, latency histogram, in-flight gauge, recognition outcomes (as a
// scrape of the metrics endpoint shows them) and the one log line per call.

#include "server/service/operations/call_interceptor.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "gtest/gtest.h"
#include "server/service/auth/call_identity.h"
#include "server/service/operations/metrics.h"
#include "tests/service/scrape.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::service {
namespace {

using ::waymark::testing::HttpGet;
using ::waymark::testing::Sample;

constexpr char kList[] = "/waymark.v1.CrossingService/ListDatabases";
constexpr char kRecognize[] = "/waymark.v1.CrossingService/RecognizeCrossing";
constexpr char kStream[] = "/waymark.v1.CrossingService/StreamRecognize";
constexpr char kRobotHeader[] = "test-robot";  // the fake's stand-in for an auth check

// Answers by script: the request's database says what happens.
//   RecognizeCrossing: "known" recognized, "nothing" not recognized, "blank" no keypoints,
//   "missing" NOT_FOUND, "boom" INTERNAL. StreamRecognize: one answer per frame, an error_code
//   for a frame whose image is "bad". A "test-robot" header is published as the caller's robot.
class ScriptedCrossingService final : public v1::CrossingService::Service {
 public:
  grpc::Status ListDatabases(grpc::ServerContext* context, const v1::ListDatabasesRequest*,
                             v1::ListDatabasesResponse*) override {
    Authenticate(context);
    return grpc::Status::OK;
  }

  grpc::Status RecognizeCrossing(grpc::ServerContext* context, const v1::RecognizeRequest* request,
                                 v1::RecognizeResponse* response) override {
    Authenticate(context);
    const std::string& db = request->database();
    if (db == "missing")
      return grpc::Status(grpc::StatusCode::NOT_FOUND, "no database \"missing\"");
    if (db == "boom") return grpc::Status(grpc::StatusCode::INTERNAL, "disk on fire");
    *response = Answer(*request);
    return grpc::Status::OK;
  }

  grpc::Status StreamRecognize(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<v1::RecognizeResponse, v1::RecognizeRequest>* stream) override {
    Authenticate(context);
    v1::RecognizeRequest request;
    while (stream->Read(&request)) {
      if (!stream->Write(Answer(request))) break;
    }
    return grpc::Status::OK;
  }

  const grpc::ServerContextBase* last_context() {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_context_;
  }

 private:
  static v1::RecognizeResponse Answer(const v1::RecognizeRequest& request) {
    v1::RecognizeResponse response;
    if (request.image().data() == "bad") {
      response.set_error_code(static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
      response.set_error_message("not an image");
      return response;
    }
    response.set_recognized(request.database() == "known");
    response.set_keypoints(request.database() == "blank" ? 0 : 100);
    return response;
  }

  void Authenticate(grpc::ServerContext* context) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      last_context_ = context;
    }
    auto it = context->client_metadata().find(kRobotHeader);
    if (it != context->client_metadata().end()) {
      SetCallRobotId(context, std::string(it->second.data(), it->second.size()));
    }
  }

  std::mutex mutex_;
  const grpc::ServerContextBase* last_context_ = nullptr;
};

// Keeps every formatted log line ("<level> <message>").
class LineSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  std::vector<std::string> Lines() {
    std::lock_guard<std::mutex> lock(mutex_);
    return lines_;
  }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t formatted;
    formatter_->format(msg, formatted);
    std::string line = fmt::to_string(formatted);
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.pop_back();
    lines_.push_back(std::move(line));
  }
  void flush_() override {}

 private:
  std::vector<std::string> lines_;
};

class CallInterceptorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    previous_logger_ = spdlog::default_logger();
    sink_ = std::make_shared<LineSink>();
    auto logger = std::make_shared<spdlog::logger>("call_interceptor_test", sink_);
    logger->set_pattern("%l %v");
    logger->set_level(spdlog::level::debug);
    spdlog::set_default_logger(logger);
  }

  void TearDown() override {
    if (server_ != nullptr) server_->Shutdown();
    spdlog::set_default_logger(previous_logger_);
  }

  // The scripted service behind the interceptor; with metrics on an ephemeral port unless
  // `with_metrics` is false.
  void StartServer(bool with_metrics = true) {
    if (with_metrics) {
      auto metrics = StartMetrics("127.0.0.1:0", MetricsSources{});
      ASSERT_TRUE(metrics.ok()) << metrics.status();
      metrics_ = std::move(*metrics);
    }
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&service_);
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
    creators.push_back(MakeCallInterceptorFactory(metrics_.get()));
    builder.experimental().SetInterceptorCreators(std::move(creators));
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    channel_ =
        grpc::CreateChannel(absl::StrCat("127.0.0.1:", port), grpc::InsecureChannelCredentials());
    stub_ = v1::CrossingService::NewStub(channel_);
  }

  static std::unique_ptr<grpc::ClientContext> Ctx(
      const std::map<std::string, std::string>& md = {}) {
    auto ctx = std::make_unique<grpc::ClientContext>();
    ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    for (const auto& [key, value] : md) ctx->AddMetadata(key, value);
    return ctx;
  }

  grpc::Status Recognize(const std::string& db, grpc::ClientContext* ctx = nullptr) {
    auto own = Ctx();
    v1::RecognizeRequest request;
    request.set_database(db);
    request.mutable_image()->set_data("jpeg");
    v1::RecognizeResponse response;
    return stub_->RecognizeCrossing(ctx != nullptr ? ctx : own.get(), request, &response);
  }

  grpc::Status List(grpc::ClientContext* ctx = nullptr) {
    auto own = Ctx();
    v1::ListDatabasesResponse response;
    return stub_->ListDatabases(ctx != nullptr ? ctx : own.get(), v1::ListDatabasesRequest(),
                                &response);
  }

  std::string Scrape() {
    absl::StatusOr<std::string> page = HttpGet(metrics_->port());
    EXPECT_TRUE(page.ok()) << page.status();
    return page.ok() ? *page : "";
  }

  // The log lines of calls ("rpc ..."), without the level.
  std::vector<std::string> RpcLines() {
    std::vector<std::string> out;
    for (const std::string& line : sink_->Lines()) {
      const size_t space = line.find(' ');
      if (line.compare(space + 1, 4, "rpc ") == 0) out.push_back(line.substr(space + 1));
    }
    return out;
  }

  static std::string RequestIdOf(const grpc::ClientContext& ctx) {
    auto it = ctx.GetServerInitialMetadata().find(kRequestIdKey);
    if (it == ctx.GetServerInitialMetadata().end()) return "";
    return std::string(it->second.data(), it->second.size());
  }

  static std::string Requests(const std::string& method, const std::string& code) {
    return absl::StrCat("waymark_rpc_requests_total{code=\"", code, "\",method=\"", method, "\"}");
  }
  static std::string ByMethod(const std::string& name, const std::string& method) {
    return absl::StrCat(name, "{method=\"", method, "\"}");
  }
  static std::string Outcome(const std::string& outcome) {
    return absl::StrCat("waymark_recognitions_total{outcome=\"", outcome, "\"}");
  }

  ScriptedCrossingService service_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<grpc::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::CrossingService::Stub> stub_;
  std::shared_ptr<LineSink> sink_;
  std::shared_ptr<spdlog::logger> previous_logger_;
};

TEST_F(CallInterceptorTest, CountsEveryCallByMethodAndCode) {
  StartServer();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(List().ok());
  for (int i = 0; i < 2; ++i)
    ASSERT_EQ(Recognize("missing").error_code(), grpc::StatusCode::NOT_FOUND);
  ASSERT_EQ(Recognize("boom").error_code(), grpc::StatusCode::INTERNAL);
  ASSERT_TRUE(Recognize("known").ok());

  const std::string page = Scrape();
  EXPECT_EQ(Sample(page, Requests(kList, "OK")), 3) << page;
  EXPECT_EQ(Sample(page, Requests(kRecognize, "NOT_FOUND")), 2) << page;
  EXPECT_EQ(Sample(page, Requests(kRecognize, "INTERNAL")), 1) << page;
  EXPECT_EQ(Sample(page, Requests(kRecognize, "OK")), 1) << page;
  EXPECT_EQ(Sample(page, Requests(kList, "NOT_FOUND")), std::nullopt) << page;
  // One latency sample per call, every one within the last (+Inf) bucket.
  EXPECT_EQ(Sample(page, ByMethod("waymark_rpc_latency_seconds_count", kList)), 3) << page;
  EXPECT_EQ(Sample(page, ByMethod("waymark_rpc_latency_seconds_count", kRecognize)), 4) << page;
  EXPECT_EQ(Sample(page, absl::StrCat("waymark_rpc_latency_seconds_bucket{method=\"", kRecognize,
                                      "\",le=\"+Inf\"}")),
            4)
      << page;
  EXPECT_EQ(Sample(page, ByMethod("waymark_rpc_in_flight", kList)), 0) << page;
  EXPECT_EQ(Sample(page, ByMethod("waymark_rpc_in_flight", kRecognize)), 0) << page;
}

TEST_F(CallInterceptorTest, CountsRecognitionOutcomesOfUnaryCallsAndStreamFrames) {
  StartServer();
  ASSERT_TRUE(Recognize("known").ok());
  ASSERT_TRUE(Recognize("known").ok());
  ASSERT_TRUE(Recognize("nothing").ok());
  ASSERT_TRUE(Recognize("blank").ok());
  ASSERT_FALSE(Recognize("missing").ok());  // a failed call is an error answer

  auto ctx = Ctx();
  auto stream = stub_->StreamRecognize(ctx.get());
  for (const char* image : {"jpeg", "bad", "jpeg"}) {
    v1::RecognizeRequest frame;
    frame.set_database("nothing");
    frame.mutable_image()->set_data(image);
    ASSERT_TRUE(stream->Write(frame));
  }
  stream->WritesDone();
  v1::RecognizeResponse answer;
  int answers = 0;
  while (stream->Read(&answer)) ++answers;
  ASSERT_TRUE(stream->Finish().ok());
  ASSERT_EQ(answers, 3);

  const std::string page = Scrape();
  EXPECT_EQ(Sample(page, Outcome("recognized")), 2) << page;
  EXPECT_EQ(Sample(page, Outcome("unknown")), 3) << page;  // 1 unary + 2 frames
  EXPECT_EQ(Sample(page, Outcome("no_features")), 1) << page;
  EXPECT_EQ(Sample(page, Outcome("error")), 2) << page;  // the failed call + the bad frame
}

TEST_F(CallInterceptorTest, StreamIsInFlightUntilItEndsAndLogsItsMessages) {
  StartServer();
  auto ctx = Ctx({{kRobotHeader, "robot-9"}});
  auto stream = stub_->StreamRecognize(ctx.get());
  v1::RecognizeRequest frame;
  frame.set_database("known");
  v1::RecognizeResponse answer;
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(stream->Write(frame));
    ASSERT_TRUE(stream->Read(&answer));
  }
  std::string page = Scrape();
  EXPECT_EQ(Sample(page, ByMethod("waymark_rpc_in_flight", kStream)), 1) << page;
  EXPECT_EQ(Sample(page, Requests(kStream, "OK")), std::nullopt) << page;

  ASSERT_TRUE(stream->Write(frame));
  stream->WritesDone();
  while (stream->Read(&answer)) {
  }
  ASSERT_TRUE(stream->Finish().ok());
  page = Scrape();
  EXPECT_EQ(Sample(page, ByMethod("waymark_rpc_in_flight", kStream)), 0) << page;
  EXPECT_EQ(Sample(page, Requests(kStream, "OK")), 1) << page;

  const std::vector<std::string> lines = RpcLines();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(absl::StartsWith(lines[0], absl::StrCat("rpc method=", kStream, " code=OK ms=")))
      << lines[0];
  EXPECT_TRUE(absl::StrContains(lines[0], " robot=robot-9 ")) << lines[0];
  EXPECT_TRUE(absl::StrContains(lines[0], " in=3 out=3")) << lines[0];
  EXPECT_TRUE(absl::StrContains(lines[0], absl::StrCat(" request_id=", RequestIdOf(*ctx), " ")))
      << lines[0];
}

TEST_F(CallInterceptorTest, GeneratesARequestIdAndSendsItBack) {
  StartServer();
  auto first = Ctx();
  auto second = Ctx();
  ASSERT_TRUE(List(first.get()).ok());
  ASSERT_TRUE(List(second.get()).ok());
  const std::string id = RequestIdOf(*first);
  EXPECT_EQ(id.size(), 16u) << id;
  EXPECT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos) << id;
  EXPECT_NE(RequestIdOf(*second), id);

  const std::vector<std::string> lines = RpcLines();
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_TRUE(absl::StrContains(lines[0], absl::StrCat(" request_id=", id, " "))) << lines[0];
}

TEST_F(CallInterceptorTest, KeepsTheClientsRequestId) {
  StartServer();
  auto ctx = Ctx({{kRequestIdKey, "robot7-frame:42"}});
  ASSERT_TRUE(List(ctx.get()).ok());
  EXPECT_EQ(RequestIdOf(*ctx), "robot7-frame:42");
  const std::vector<std::string> lines = RpcLines();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(absl::StrContains(lines[0], " request_id=robot7-frame:42 ")) << lines[0];
}

TEST_F(CallInterceptorTest, ReplacesAnImplausibleRequestId) {
  StartServer();
  for (const std::string& bad :
       {std::string("two words"), std::string("a=b"), std::string(65, 'x')}) {
    auto ctx = Ctx({{kRequestIdKey, bad}});
    ASSERT_TRUE(List(ctx.get()).ok());
    EXPECT_EQ(RequestIdOf(*ctx).size(), 16u) << bad;
    EXPECT_NE(RequestIdOf(*ctx), bad);
  }
}

TEST_F(CallInterceptorTest, LogsOneLinePerCallWithMethodCodeRobotPeerAndError) {
  StartServer();
  auto ctx = Ctx({{kRobotHeader, "robot-7"}, {kRequestIdKey, "req-1"}});
  ASSERT_EQ(Recognize("missing", ctx.get()).error_code(), grpc::StatusCode::NOT_FOUND);
  ASSERT_TRUE(List().ok());

  const std::vector<std::string> lines = RpcLines();
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_TRUE(
      absl::StartsWith(lines[0], absl::StrCat("rpc method=", kRecognize, " code=NOT_FOUND ms=")))
      << lines[0];
  EXPECT_TRUE(absl::StrContains(lines[0], " request_id=req-1 robot=robot-7 peer=ipv4:127.0.0.1:"))
      << lines[0];
  EXPECT_TRUE(absl::EndsWith(lines[0], " error=\"no database \\\"missing\\\"\"")) << lines[0];
  EXPECT_FALSE(absl::StrContains(lines[0], " in=")) << "unary calls carry no message counts";
  // No auth check published a robot for the second call.
  EXPECT_TRUE(absl::StrContains(lines[1], " robot=- ")) << lines[1];
  EXPECT_FALSE(absl::StrContains(lines[1], "error=")) << lines[1];
}

TEST_F(CallInterceptorTest, ServerFailuresAreLoggedAsWarnings) {
  StartServer();
  ASSERT_EQ(Recognize("boom").error_code(), grpc::StatusCode::INTERNAL);
  ASSERT_EQ(Recognize("missing").error_code(), grpc::StatusCode::NOT_FOUND);
  std::vector<std::string> lines;
  for (const std::string& line : sink_->Lines()) {
    if (absl::StrContains(line, " rpc ")) lines.push_back(line);
  }
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_TRUE(absl::StartsWith(lines[0], "warning rpc ")) << lines[0];
  EXPECT_TRUE(absl::StartsWith(lines[1], "info rpc ")) << lines[1];
}

// A load balancer's health watch ends when it cancels it: gRPC's health service then answers
// UNKNOWN "OnCancel()". That is the client's doing, not a server failure: logged CANCELLED at
// debug level, counted CANCELLED.
TEST_F(CallInterceptorTest, ACancelledHealthWatchIsNotAServerFailure) {
  grpc::EnableDefaultHealthCheckService(true);  // read when a server is built: this one only
  StartServer();
  grpc::EnableDefaultHealthCheckService(false);
  grpc::health::v1::Health::Stub health(channel_);
  grpc::ClientContext ctx;
  grpc::health::v1::HealthCheckRequest request;
  auto watch = health.Watch(&ctx, request);
  grpc::health::v1::HealthCheckResponse response;
  ASSERT_TRUE(watch->Read(&response));  // the first answer: SERVING
  ctx.TryCancel();
  while (watch->Read(&response)) {
  }
  EXPECT_EQ(watch->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // The server logs the call when its status is sent, after the client saw the cancel.
  std::string line;
  for (int i = 0; i < 500 && line.empty(); ++i) {
    for (const std::string& l : sink_->Lines()) {
      if (absl::StrContains(l, "grpc.health.v1.Health/Watch")) line = l;
    }
    if (line.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_FALSE(line.empty()) << "the watch was never logged";
  EXPECT_TRUE(absl::StartsWith(line, "debug rpc ")) << line;
  EXPECT_TRUE(absl::StrContains(line, " code=CANCELLED ")) << line;
  EXPECT_FALSE(absl::StrContains(line, "OnCancel")) << line;
  EXPECT_THAT(Scrape(), ::testing::Not(::testing::HasSubstr(
                            "code=\"UNKNOWN\",method=\"/grpc.health.v1.Health/Watch\"")));
}

TEST_F(CallInterceptorTest, TheCallsRobotIdIsTakenWhenItEnds) {
  StartServer();
  ASSERT_TRUE(List(Ctx({{kRobotHeader, "robot-7"}}).get()).ok());
  const grpc::ServerContextBase* context = service_.last_context();
  ASSERT_NE(context, nullptr);
  EXPECT_EQ(TakeCallRobotId(context), "");
}

TEST_F(CallInterceptorTest, AnUnknownMethodIsCountedWithoutTheClientsPath) {
  StartServer();
  grpc::GenericStub generic(channel_);
  grpc::Slice empty_message("");
  grpc::ByteBuffer request(&empty_message, 1);
  grpc::ByteBuffer response;
  grpc::Status status;
  std::mutex mutex;
  std::condition_variable done_cv;
  bool done = false;
  auto ctx = Ctx();
  generic.UnaryCall(ctx.get(), "/waymark.v1.CrossingService/NoSuchMethod", grpc::StubOptions(),
                    &request, &response, [&](grpc::Status s) {
                      std::lock_guard<std::mutex> lock(mutex);
                      status = s;
                      done = true;
                      done_cv.notify_all();
                    });
  {
    std::unique_lock<std::mutex> lock(mutex);
    done_cv.wait(lock, [&] { return done; });
  }
  ASSERT_EQ(status.error_code(), grpc::StatusCode::UNIMPLEMENTED);
  const std::string page = Scrape();
  EXPECT_FALSE(absl::StrContains(page, "NoSuchMethod")) << page;
  const std::vector<std::string> lines = RpcLines();
  ASSERT_EQ(lines.size(), 1u);
  // gRPC names every unregistered method "unknown": the label set stays bounded.
  EXPECT_EQ(Sample(page, Requests("unknown", "UNIMPLEMENTED")), 1) << page;
  EXPECT_TRUE(absl::StartsWith(lines[0], "rpc method=unknown code=UNIMPLEMENTED ")) << lines[0];
}

TEST_F(CallInterceptorTest, WithoutMetricsStillLogsAndSendsRequestIds) {
  StartServer(/*with_metrics=*/false);
  auto ctx = Ctx();
  ASSERT_TRUE(Recognize("known", ctx.get()).ok());
  EXPECT_EQ(RequestIdOf(*ctx).size(), 16u);
  const std::vector<std::string> lines = RpcLines();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(absl::StrContains(lines[0], " code=OK ")) << lines[0];
}

}  // namespace
}  // namespace waymark::service
