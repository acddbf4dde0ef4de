#ifndef WAYMARK_TESTS_CLIENT_FAKE_CROSSING_SERVICE_H_
#define WAYMARK_TESTS_CLIENT_FAKE_CROSSING_SERVICE_H_

#include <grpcpp/server.h>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::testing {

// An in-memory stand-in for CrossingService, so the client and the CLI can be tested without the
// real server. Recognition is by identity: a query whose bytes equal an enrolled view's bytes is
// recognized as that view; anything else is not. Enrollment compares bytes as the server compares
// hashes (the same bytes again are a DUPLICATE, `replace` as in crossing.proto), and an empty image
// is the one invalid view. Streamed frames (re-encoded by the camera, so
// never identical) must decode as images and are recognized from frame `stream_recognize_from`.
class FakeCrossingService final : public v1::CrossingService::Service {
 public:
  struct View {
    std::string crossing;
    double heading_deg = 0;
    std::string bytes;
    bool store_image = false;
    int64_t id = 0;
    std::string position;
    bool heading_unknown = false;  // EnrollViewRequest.heading_unknown
  };

  // Test hooks; set before calls, read after.
  void FailNextWithUnavailable(const std::string& method, int times);
  void set_delay(absl::Duration delay) { delay_ = delay; }
  void set_stream_recognize_from(int frame) { stream_recognize_from_ = frame; }
  // Called by StreamEnroll before it enrolls the view at `index` (on the server's thread).
  void set_on_enroll(std::function<void(int index)> hook);
  // Called by RecognizeCrossing with its answer, to edit it (under the service's lock).
  using RecognizeHook =
      std::function<void(const v1::RecognizeRequest& request, v1::RecognizeResponse* answer)>;
  void set_on_recognize(RecognizeHook hook);
  int calls(const std::string& method) const;
  std::vector<View> views(const std::string& database) const;
  v1::CreateDatabaseRequest last_create() const;
  v1::RecognitionParams last_params() const;
  std::vector<std::pair<int, int>> stream_frame_sizes() const;

  grpc::Status CreateDatabase(grpc::ServerContext*, const v1::CreateDatabaseRequest* request,
                              v1::CrossingDatabase* response) override;
  grpc::Status ListDatabases(grpc::ServerContext*, const v1::ListDatabasesRequest*,
                             v1::ListDatabasesResponse* response) override;
  grpc::Status DeleteDatabase(grpc::ServerContext*, const v1::DeleteDatabaseRequest* request,
                              v1::DeleteDatabaseResponse*) override;
  grpc::Status GetDatabaseStats(grpc::ServerContext*, const v1::GetDatabaseStatsRequest* request,
                                v1::DatabaseStats* response) override;
  grpc::Status AddCrossing(grpc::ServerContext*, const v1::AddCrossingRequest* request,
                           v1::Crossing* response) override;
  grpc::Status ListCrossings(grpc::ServerContext*, const v1::ListCrossingsRequest* request,
                             v1::ListCrossingsResponse* response) override;
  grpc::Status DeleteCrossing(grpc::ServerContext*, const v1::DeleteCrossingRequest* request,
                              v1::DeleteCrossingResponse* response) override;
  grpc::Status BulkEnroll(grpc::ServerContext*, grpc::ServerReader<v1::EnrollViewRequest>* reader,
                          v1::BulkEnrollResponse* response) override;
  grpc::Status StreamEnroll(
      grpc::ServerContext*,
      grpc::ServerReaderWriter<v1::EnrollViewResponse, v1::EnrollViewRequest>* stream) override;
  grpc::Status RecognizeCrossing(grpc::ServerContext*, const v1::RecognizeRequest* request,
                                 v1::RecognizeResponse* response) override;
  grpc::Status StreamRecognize(
      grpc::ServerContext*,
      grpc::ServerReaderWriter<v1::RecognizeResponse, v1::RecognizeRequest>* stream) override;

 private:
  static constexpr int kKeypointsPerView = 100;

  struct Database {
    v1::CrossingDatabase info;
    std::map<std::string, v1::Crossing> crossings;
    std::vector<View> views;
  };

  // Enrolls one view of BulkEnroll or StreamEnroll; an error ends the stream.
  grpc::Status EnrollOne(const v1::EnrollViewRequest& request, v1::EnrollViewResponse* answer);
  // Counts the call, sleeps the configured delay and consumes an injected failure.
  grpc::Status Enter(const std::string& method);
  // Requires mutex_.
  Database* Find(const std::string& name);
  v1::CrossingDatabase Summary(const Database& db) const;

  mutable std::mutex mutex_;
  std::map<std::string, Database> databases_;
  std::map<std::string, int> calls_;
  std::map<std::string, int> failures_;
  absl::Duration delay_ = absl::ZeroDuration();
  int stream_recognize_from_ = 0;
  std::function<void(int)> on_enroll_;
  RecognizeHook on_recognize_;
  int64_t next_id_ = 1;
  v1::CreateDatabaseRequest last_create_;
  v1::RecognitionParams last_params_;
  std::vector<std::pair<int, int>> stream_frame_sizes_;
};

// The fake served on a free localhost port.
class FakeServer {
 public:
  FakeServer();
  ~FakeServer();
  FakeCrossingService& service() { return service_; }
  const std::string& address() const { return address_; }

 private:
  FakeCrossingService service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_CLIENT_FAKE_CROSSING_SERVICE_H_
