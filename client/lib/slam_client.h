#ifndef WAYMARK_CLIENT_LIB_SLAM_CLIENT_H_
#define WAYMARK_CLIENT_LIB_SLAM_CLIENT_H_

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>
#include <grpcpp/support/sync_stream.h>

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <unordered_map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_set>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/lib/crossing_streams.h"  // Deadline
#include "client/lib/retry.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark::client {

struct SlamClientOptions {
  // Deadline of every unary call, retries and backoff included. InfiniteDuration() disables it.
  absl::Duration timeout = absl::Seconds(30);
  // Deadline of a whole StreamSensorData stream; a robot streams for as long as it drives.
  absl::Duration stream_timeout = absl::InfiniteDuration();
  // Applied to GetMap, GetTrajectory, GetOccupancyGrid and ListSessions only (reads).
  // CreateSession, CloseSession, DeleteSession and ImportMap are never retried (a retry could
  // apply them twice).
  RetryOptions retry;
  // Several servers on one database (docs/scale-out.md): a session is served by one of them, and
  // the others refuse its stream naming that server (trailing metadata waymark-session-owner).
  // With `connect` set, the next stream of that session goes straight there (a channel made by
  // `connect`), and back to the channel's own servers once the named one is unreachable (dead:
  // its lease expires and any server takes the session over). Unset: the refusal is an error the
  // caller retries like any other.
  std::function<std::shared_ptr<grpc::ChannelInterface>(const std::string& address)> connect;
};

// Which server serves which session, as the servers' refusals said (shared by a SlamClient and
// its streams).
class SessionRoutes {
 public:
  std::string Get(const std::string& session_id) const;
  void Set(const std::string& session_id, const std::string& address);
  void Clear(const std::string& session_id);

 private:
  mutable std::mutex mutex_;
  std::unordered_map<std::string, std::string> owner_;
};

// Scans allowed in flight on one stream by default: well under the server's default session
// queue (64 messages), with room for the odometry message that precedes each scan.
inline constexpr int kDefaultScanWindow = 16;
// Frames allowed in flight on a visual session's stream by default: enough to keep the session's
// worker busy while the next frame travels, few enough that a slow session does not buffer
// seconds of camera frames (each is ~0.1-1 MB).
inline constexpr int kDefaultFrameWindow = 4;

// Client side of SlamService.StreamSensorData with flow control: at most `window` scans are
// outstanding (sent and not yet answered by a SlamUpdate; a rejection counts as an answer), so a
// sender faster than the session never overflows the server's bounded session queue. Odometry
// messages are not answered unless rejected, and are not windowed (each precedes a scan).
// Visual sessions send image frames instead: each is answered like a scan and shares its window.
//
// Updates are read on an internal thread and handed to `on_update` (on that thread); the answer to
// a hello is not an update (see Hello()). Send* and Finish() belong to one thread.
class SensorStream {
 public:
  using UpdateCallback = std::function<void(const v1::SlamUpdate&)>;

  struct Stats {
    uint64_t scans_sent = 0;
    uint64_t odometry_sent = 0;
    uint64_t updates = 0;           // processed scans or frames (no rejection)
    uint64_t scans_rejected = 0;    // scan answered with a rejection
    uint64_t odometry_rejected = 0;
    uint64_t frames_sent = 0;       // image frames (visual sessions)
    uint64_t frames_rejected = 0;   // frame answered with a rejection
    uint64_t queue_full = 0;        // rejections with RESOURCE_EXHAUSTED (any message)
    int max_outstanding = 0;        // the most scans ever in flight
  };

  // `routes` (optional) learns from the stream's end where its session is served; `via` is the
  // address the stream was sent to when it followed such a route ("" = the client's channel).
  SensorStream(v1::SlamService::StubInterface* stub, std::string session_id, int window,
               Deadline deadline, UpdateCallback on_update,
               std::shared_ptr<SessionRoutes> routes = nullptr, std::string via = "");
  ~SensorStream();
  SensorStream(const SensorStream&) = delete;
  SensorStream& operator=(const SensorStream&) = delete;

  // Sends one odometry reading. A false-y status means the stream broke; Finish() says why.
  absl::Status SendOdometry(const v1::Odometry& odometry);
  // Waits until fewer than `window` scans are outstanding, then sends the scan.
  absl::Status SendScan(const v1::LaserScan& scan);
  // Visual sessions: waits like SendScan (frames and scans share the window), then sends.
  absl::Status SendFrame(const v1::ImageFrame& frame);
  // Sends a hello (the session id, no payload) as the stream's first message and waits for its
  // answer: what the session holds (StreamStart), learnt before any data is sent. UNAVAILABLE
  // when the stream ends first (Finish() says why), DEADLINE_EXCEEDED after `timeout`.
  absl::StatusOr<v1::StreamStart> Hello(absl::Duration timeout);
  // The StreamStart of the stream's first answer (or of the hello's), once it has arrived.
  std::optional<v1::StreamStart> start() const;
  // Waits until every scan sent so far is answered (a rejection counts). DEADLINE_EXCEEDED after
  // `timeout`, UNAVAILABLE if the stream ended first. The update callback of the last answer has
  // returned by then.
  absl::Status WaitIdle(absl::Duration timeout);
  // How long SendScan waits on a full window before giving up (default 120 s). A robot wants to
  // know sooner that its server hangs.
  void set_answer_timeout(absl::Duration timeout) { answer_timeout_ = timeout; }
  // True once the server ended the stream (or it broke); Finish() says why.
  bool ended() const;
  // Called once when the stream ends for any reason, on the reader thread (at once, on the
  // caller's thread, if it already has): a robot stops its motors here rather than at its next
  // send.
  void set_end_callback(std::function<void()> callback);
  // Half-closes, waits for every outstanding answer and returns the stream's final status.
  absl::Status Finish();
  // After Finish: the server that serves the session, when this one refused it for that reason.
  const std::string& session_owner() const { return session_owner_; }
  // The server this stream was sent to because the session is served there ("" = the client's
  // own channel).
  const std::string& routed_to() const { return via_; }
  // Aborts from any thread.
  void Cancel();

  int window() const { return window_; }
  int outstanding() const;
  Stats stats() const;

 private:
  absl::Status Send(v1::SensorData& message);
  // Waits for room in the window, numbers `message` and counts it as outstanding.
  absl::Status SendWindowed(v1::SensorData& message, bool is_frame);
  void ReadLoop();

  const int window_;
  const std::string session_id_;
  UpdateCallback on_update_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriterInterface<v1::SensorData, v1::SlamUpdate>> stream_;
  std::thread reader_;

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::unordered_set<uint64_t> outstanding_scans_;  // sequences of scans and frames
  std::unordered_set<uint64_t> outstanding_frames_;  // the frames among them
  std::unordered_set<uint64_t> odometry_sequences_;  // only kept to classify rejections
  std::optional<v1::StreamStart> start_;
  bool hello_outstanding_ = false;  // sent, not yet answered (its answer is no update)
  Stats stats_;
  absl::Duration answer_timeout_ = absl::Seconds(120);
  std::function<void()> on_end_;
  bool read_done_ = false;
  bool first_sent_ = false;
  bool finished_ = false;
  uint64_t next_sequence_ = 1;
  std::shared_ptr<SessionRoutes> routes_;
  const std::string via_;
  std::string session_owner_;
};

// Typed, blocking access to waymark.v1.SlamService. Thread-safe; streams are per caller.
class SlamClient {
 public:
  explicit SlamClient(std::shared_ptr<grpc::ChannelInterface> channel,
                      SlamClientOptions options = {});
  explicit SlamClient(std::unique_ptr<v1::SlamService::StubInterface> stub,
                      SlamClientOptions options = {});

  const SlamClientOptions& options() const { return options_; }

  absl::StatusOr<v1::Session> CreateSession(const v1::CreateSessionRequest& request);
  absl::StatusOr<v1::SegmentMap> GetMap(const std::string& session_id);
  absl::StatusOr<v1::Trajectory> GetTrajectory(const std::string& session_id);
  // The session's occupancy grid; `resolution` (m per cell) unset = the server's default (0.05).
  // FAILED_PRECONDITION for a session that keeps no scans (loop closure off).
  absl::StatusOr<v1::OccupancyGrid> GetOccupancyGrid(
      const std::string& session_id, std::optional<double> resolution = std::nullopt);
  // Stores `grid` as a new closed laser session to localize on (see the proto).
  absl::StatusOr<v1::Session> ImportMap(const std::string& robot_id, const std::string& name,
                                        const v1::OccupancyGrid& grid);
  // Closing a laser session waits for its loop-closing back end to finish (its last searches and
  // optimisation: tens of seconds after a fast replay of a large log), so its deadline is the
  // longer of options.timeout and kCloseSessionTimeout.
  static constexpr absl::Duration kCloseSessionTimeout = absl::Minutes(10);
  absl::StatusOr<v1::Session> CloseSession(const std::string& session_id);
  absl::StatusOr<v1::ListSessionsResponse> ListSessions(const std::string& robot_id = "");
  // Deletes a session and its stored data; `force` closes an open session first (see the proto).
  absl::StatusOr<v1::DeleteSessionResponse> DeleteSession(const std::string& session_id,
                                                          bool force = false);

  // Maps shared by robots (slam.proto, CreateMap ...). Reads are retried as the session reads;
  // CreateMap and DeleteMap never are.
  absl::StatusOr<v1::Map> CreateMap(const std::string& name);
  absl::StatusOr<v1::ListMapsResponse> ListMaps();
  // `node_origins`: also each followed trajectory's origin at every node (GetMapInfoRequest).
  absl::StatusOr<v1::Map> GetMapInfo(const std::string& name, bool node_origins = false);
  absl::StatusOr<v1::DeleteMapResponse> DeleteMap(const std::string& name, bool force = false);
  absl::StatusOr<v1::MapOccupancyGrid> GetMapOccupancyGrid(
      const std::string& name, std::optional<double> resolution = std::nullopt);
  absl::StatusOr<v1::MapSegmentMap> GetMapSegments(const std::string& name);

  // Makes the channel try to connect now instead of at the end of gRPC's reconnect backoff, which
  // after a server restart can hold calls failing for seconds. A robot calls it before reopening
  // a broken stream. No-op for a client built on a stub.
  void ResetConnectBackoff();
  // Waits up to `timeout` for the channel to be connected (trying to connect); true once it is.
  // Always true for a client built on a stub.
  bool WaitForConnected(absl::Duration timeout);

  // Opens StreamSensorData for `session_id` (the call starts immediately).
  std::unique_ptr<SensorStream> StreamSensorData(const std::string& session_id,
                                                 int window = kDefaultScanWindow,
                                                 SensorStream::UpdateCallback on_update = {});

 private:
  // The stub for a server another one named (cached: one channel per address).
  v1::SlamService::StubInterface* StubAt(const std::string& address);
  // A unary call on one session: on the client's channel, and once more on the server a refusal
  // names as the session's (with options.connect), as streams do.
  template <typename Response, typename Call>
  absl::StatusOr<Response> AtSessionServer(const std::string& session_id, absl::Duration timeout,
                                           Call call);

  std::unique_ptr<v1::SlamService::StubInterface> stub_;
  std::shared_ptr<grpc::ChannelInterface> channel_;  // null when built on a stub
  SlamClientOptions options_;
  std::shared_ptr<SessionRoutes> routes_ = std::make_shared<SessionRoutes>();
  std::mutex stubs_mutex_;
  std::unordered_map<std::string, std::unique_ptr<v1::SlamService::StubInterface>> stubs_;
};

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_SLAM_CLIENT_H_
