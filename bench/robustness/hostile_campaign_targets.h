#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_TARGETS_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_TARGETS_H_

// waymark-hostile-campaign: what is attacked. Every RPC of the API's services (CrossingService,
// SlamService, TokenService) and of grpc.health.v1.Health, enumerated from the generated
// descriptors so that an RPC added later is covered without a change here, each with a source of
// valid requests to mutate. The valid requests are real ones: they name databases, crossings,
// sessions and tokens the campaign created on the server (Fixtures), carry real JPEG views of a
// generated crossing and laser scans of a room the odometry agrees with.

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <functional>
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "bench/robustness/hostile_campaign_mutations.h"
#include "waymark/v1/crossing.pb.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::bench::hostile {

enum class RpcKind { kUnary, kClientStream, kServerStream, kBidiStream };
std::string KindName(RpcKind kind);

// The valid messages of one call, in order (a stream's first one opens it, e.g. names the
// session; the following ones carry fresh stamps).
using MessageSource = std::function<std::unique_ptr<google::protobuf::Message>()>;

struct RpcTarget {
  const google::protobuf::MethodDescriptor* method = nullptr;
  std::string path;  // "/waymark.v1.CrossingService/EnrollView", as gRPC addresses it
  std::string name;  // "CrossingService/EnrollView"
  RpcKind kind = RpcKind::kUnary;
  // false: no hand-made request yet (an RPC added since this campaign was written); its
  // requests are filled field by field through reflection.
  bool hand_made = false;
  // The valid messages of a new call made by campaign thread `thread` (streams of one session
  // are one per thread: the server allows one stream per session).
  std::function<MessageSource(int thread, Rng& rng)> begin_call;
  // Undoes what an accepted call created (a database, a session), so that the server's limits
  // (64 open sessions) do not turn every later request into RESOURCE_EXHAUSTED and the memory
  // measured is not the campaign's own data. `request` is the call's first message.
  std::function<void(const std::string& request, const std::vector<std::string>& answers)> on_ok;
  // After the RPC's whole batch: drops what it stored on purpose (enrolled views).
  std::function<void()> after_batch;
};

// What the campaign creates on a fresh server before attacking it.
class Fixtures {
 public:
  // Names of what the requests address.
  static constexpr const char* kRecognizeDb = "recognize-db";  // 2 crossings x 4 views, untouched
  static constexpr const char* kEnrollDb = "enroll-db";        // enrollment target, reset per batch
  static constexpr const char* kEditDb = "edit-db";            // AddCrossing / DeleteCrossing
  static constexpr const char* kVictimDb = "victim-db";        // DeleteDatabase
  static constexpr const char* kRebuildDb = "rebuild-db";      // RebuildClusters
  static constexpr const char* kVictimCrossing = "victim-crossing";
  static constexpr const char* kVictimToken = "victim-token";

  // Creates everything through `channel` (which carries an admin token when auth is on);
  // `threads` campaign threads get a laser and a visual session each.
  static absl::StatusOr<std::unique_ptr<Fixtures>> Create(std::shared_ptr<grpc::Channel> channel,
                                                          int threads);

  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  // A robot's query of crossing 1 exactly as enrolled (recognized, when the server works).
  v1::RecognizeRequest KnownQuery() const;
  // A fresh laser session request of `robot`, the room scans' geometry.
  static v1::CreateSessionRequest LaserSession(const std::string& robot);
  int cleanups_failed() const { return cleanups_failed_.load(); }

  // Deletes and re-creates `database` empty (an enrollment batch's views go with it).
  void ResetDatabase(const std::string& database);
  void DeleteDatabase(const std::string& name);
  void DeleteCrossing(const std::string& database, const std::string& name);
  void DeleteSession(const std::string& id);

  std::string laser_session(int thread) const { return laser_sessions_[thread]; }
  std::string visual_session(int thread) const { return visual_sessions_[thread]; }
  const std::string& read_session() const { return read_session_; }
  const std::string& victim_close_session() const { return victim_close_; }
  const std::string& victim_delete_session() const { return victim_delete_; }
  // Encoded views: JPEG of `crossing`'s panorama at `heading` (320 x 240).
  static std::string View(int crossing, double heading);
  // The visual sessions' camera frame (PNG, 160 x 120) and a depth image of it.
  static std::string CameraFrame(int index);
  static std::string DepthFrame();

  // Per-thread counters that keep each session's stamps increasing across calls.
  double NextStamp(int thread) { return stamps_[thread].fetch_add(1) * 0.05 + 1.0; }

 private:
  explicit Fixtures(std::shared_ptr<grpc::Channel> channel, int threads);
  absl::Status CreateCrossingDatabases();
  absl::Status CreateSessions(int threads);

  std::shared_ptr<grpc::Channel> channel_;
  std::vector<std::string> laser_sessions_, visual_sessions_;
  std::string read_session_, victim_close_, victim_delete_;
  std::unique_ptr<std::atomic<int64_t>[]> stamps_;
  std::atomic<int> cleanups_failed_{0};
};

// The databases' parameters: a small working resolution and keypoint budget keep SIFT cheap on
// a 2-core machine without changing what the server does with a request.
v1::DatabaseParams FixtureDatabaseParams();

// Every RPC of the services in proto/ with its source of valid requests.
std::vector<RpcTarget> EnumerateTargets(Fixtures& fixtures);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_TARGETS_H_
