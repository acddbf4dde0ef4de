#ifndef WAYMARK_TESTS_CLIENT_FAKE_SLAM_SERVICE_H_
#define WAYMARK_TESTS_CLIENT_FAKE_SLAM_SERVICE_H_

#include <grpcpp/server.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark::testing {

// An in-memory stand-in for SlamService. Like the real server it queues stream messages in a
// bounded per-session queue (capacity `queue_capacity`, RESOURCE_EXHAUSTED rejection when full)
// and processes them on a worker that takes `scan_delay` per scan; the "SLAM" is dead reckoning
// (the pose of a scan is the last odometry pose) and one segment per `scans_per_segment` scans.
// It records the most scans it ever held received-but-unanswered, so tests can check a client's
// flow control, and rejects per-sensor stamps that do not increase (INVALID_ARGUMENT).
// Closing a closed session is FAILED_PRECONDITION "... is already closed", as on the real server.
// For exploration clients it can answer every scan with a fixed suggested control (set_suggestion)
// and a covariance_trace_mean growing with the scan count, and it keeps the stamps it received;
// with set_exploration_end, a goal layer's progress that ends in DONE or STUCK.
// Visual clients' image frames are answered like scans (a pose3d at x = stamp, "tracking").
// Like the real server, a stream's first answer carries its StreamStart, and a hello (a first
// message without payload) is answered at once with it.
// Occupancy grids: GetOccupancyGrid answers the grid given to set_occupancy_grid for every
// session (FAILED_PRECONDITION "keeps no scans" without one, as the real server for a session with
// loop closure off), and an imported session's own grid; ImportMap stores a grid as a new closed
// session, refusing one whose cells do not fill it. A session created with
// LaserSlamConfig.localize needs a closed map session (NOT_FOUND, FAILED_PRECONDITION) and answers
// its scans localized from the scan set_localized_from_scan names on.
class FakeSlamService final : public v1::SlamService::Service {
 public:
  // Every laser session's grid (session_id filled in per call).
  void set_occupancy_grid(const v1::OccupancyGrid& grid) {
    std::lock_guard<std::mutex> lock(mutex_);
    grid_ = grid;
  }
  // GetOccupancyGrid answers `code` (OK: as above), e.g. UNIMPLEMENTED as an older server.
  void set_grid_answer(grpc::StatusCode code) {
    std::lock_guard<std::mutex> lock(mutex_);
    grid_answer_ = code;
  }
  // Every mapping session's GetMap carries this self-check and, once closed, its Session (without
  // the cells), as the real server's; unset (the default): none, as a server older than it.
  void set_map_self_check(const v1::MapSelfCheck& check) {
    std::lock_guard<std::mutex> lock(mutex_);
    self_check_ = check;
  }
  // Localization sessions: scan number `scan` (1 = the first processed) and later ones are
  // answered localized. Default 3.
  void set_localized_from_scan(int scan) {
    std::lock_guard<std::mutex> lock(mutex_);
    localized_from_scan_ = scan;
  }
  // The next `times` calls of `method` ("GetOccupancyGrid" or "ImportMap") fail with `code`
  // before reaching the service: UNAVAILABLE as a dropped connection, UNIMPLEMENTED as a server
  // older than the RPC.
  void FailNext(const std::string& method, int times,
                grpc::StatusCode code = grpc::StatusCode::UNAVAILABLE) {
    std::lock_guard<std::mutex> lock(mutex_);
    fail_next_[method] = {times, code};
  }
  // Sessions created with LaserSlamConfig.localize map instead and answer no localization status,
  // as a server older than the field.
  void set_ignore_localize(bool ignore) {
    std::lock_guard<std::mutex> lock(mutex_);
    ignore_localize_ = ignore;
  }
  // Calls of "GetOccupancyGrid" or "ImportMap" received, failed ones included.
  int calls(const std::string& method) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = calls_.find(method);
    return it == calls_.end() ? 0 : it->second;
  }
  // The resolution of the last GetOccupancyGrid (nullopt: it left it unset).
  std::optional<double> last_grid_resolution() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_grid_resolution_;
  }
  v1::ImportMapRequest last_import() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_import_;
  }

  void set_scan_delay(absl::Duration delay) { scan_delay_ = delay; }
  void set_queue_capacity(int capacity) { queue_capacity_ = capacity; }
  // The worker of a stream starts only once the stream has received `messages` messages (or
  // ended): the client's messages then pile up as on a busy server, however fast or slow this
  // machine runs the client and the worker. 0 = start at once.
  void set_hold_until_received(int messages) {
    std::lock_guard<std::mutex> lock(mutex_);
    hold_until_received_ = messages;
  }
  // Attached to every scan's update; the default (BEHAVIOUR_UNSPECIFIED) attaches none, as a
  // passive session does.
  void set_suggestion(const v1::SuggestedControl& suggestion);
  // Goal layer progress on every scan's update: EXPLORING (half the boundary open, 2 targets
  // left) before the session's scan number `scan` (1 = the first processed), then `state` (DONE
  // or STUCK) with `reason` and a FINISHED suggestion of (0, 0) instead of set_suggestion's, as
  // the real server answers once exploration has ended. 0 = no progress (the default).
  void set_exploration_end(int scan, v1::ExplorationProgress::State state,
                           const std::string& reason);
  // Every stream ends with UNAVAILABLE when its scan (or frame) number `scans` + 1 arrives (that
  // scan is not answered): a server or network that dies under a robot. 0 = never.
  void set_break_streams_after(int scans) {
    std::lock_guard<std::mutex> lock(mutex_);
    break_streams_after_ = scans;
  }
  // CloseSession, GetMap and GetTrajectory answer `code` (OK: normally): a server that went away
  // with a stream.
  void set_session_calls_fail(grpc::StatusCode code) {
    std::lock_guard<std::mutex> lock(mutex_);
    session_calls_fail_ = code;
  }
  // With a break: the session then loses every scan after its first `scans` (its trajectory, count
  // and stamps go back), and the next stream starts "from_checkpoint": a server that crashed and
  // resumed the session from an old checkpoint. -1 = keep everything.
  void set_rollback_on_break(int scans) {
    std::lock_guard<std::mutex> lock(mutex_);
    rollback_on_break_ = scans;
  }
  // The first stream refuses every scan (or frame) after its first `scans` with an UNAVAILABLE
  // rejection (not recorded as received) and goes on, as a server that is shutting down but has
  // not ended its streams yet. 0 = never.
  void set_refuse_first_stream_after(int scans) {
    std::lock_guard<std::mutex> lock(mutex_);
    refuse_first_stream_after_ = scans;
  }
  int streams_opened() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return streams_opened_;
  }
  // Stamps of the messages received, in arrival order (rejected ones included); frames are among
  // the scans.
  std::vector<double> odometry_stamps() const;
  std::vector<double> scan_stamps() const;
  int max_outstanding_scans() const;
  int scans_received() const;
  int odometry_received() const;
  int rejected() const;
  v1::CreateSessionRequest last_create() const;

  grpc::Status CreateSession(grpc::ServerContext*, const v1::CreateSessionRequest* request,
                             v1::Session* response) override;
  grpc::Status StreamSensorData(
      grpc::ServerContext*,
      grpc::ServerReaderWriter<v1::SlamUpdate, v1::SensorData>* stream) override;
  grpc::Status GetMap(grpc::ServerContext*, const v1::GetMapRequest* request,
                      v1::SegmentMap* response) override;
  grpc::Status GetTrajectory(grpc::ServerContext*, const v1::GetTrajectoryRequest* request,
                             v1::Trajectory* response) override;
  grpc::Status CloseSession(grpc::ServerContext*, const v1::CloseSessionRequest* request,
                            v1::Session* response) override;
  grpc::Status ListSessions(grpc::ServerContext*, const v1::ListSessionsRequest* request,
                            v1::ListSessionsResponse* response) override;
  // As the real server: NOT_FOUND, FAILED_PRECONDITION for an open session without force.
  grpc::Status DeleteSession(grpc::ServerContext*, const v1::DeleteSessionRequest* request,
                             v1::DeleteSessionResponse* response) override;
  grpc::Status GetOccupancyGrid(grpc::ServerContext*, const v1::GetOccupancyGridRequest* request,
                                v1::OccupancyGrid* response) override;
  grpc::Status ImportMap(grpc::ServerContext*, const v1::ImportMapRequest* request,
                         v1::Session* response) override;

 private:
  struct SessionData {
    v1::Session info;
    v1::Trajectory trajectory;
    v1::SegmentMap map;
    v1::Pose2D odometry;
    double last_odometry_stamp = -1e300;
    double last_scan_stamp = -1e300;
    bool resumed_from_checkpoint = false;  // rolled back: the next stream says so
    std::optional<v1::OccupancyGrid> imported;  // ImportMap's grid
    bool localizing = false;                    // created with LaserSlamConfig.localize
    uint32_t fixes = 0;
  };
  // Counts a call of `method`; the status to fail it with (FailNext), or OK to serve it.
  grpc::Status CountCall(const std::string& method);
  // The session as a stream finds it when it attaches.
  static v1::StreamStart StartOf(const SessionData& session);
  // Forgets everything after the first `scans` scans (set_rollback_on_break).
  static void RollBack(SessionData& session, int scans);
  // Answers a scan or a frame that was accepted: the session's count, pose and map move on.
  v1::SlamUpdate Process(SessionData& session, const v1::SensorData& message);
  static constexpr int kScansPerSegment = 10;

  mutable std::mutex mutex_;
  std::map<std::string, SessionData> sessions_;
  int next_id_ = 1;
  absl::Duration scan_delay_ = absl::ZeroDuration();
  int queue_capacity_ = 64;
  int max_outstanding_ = 0;
  int scans_received_ = 0;
  int odometry_received_ = 0;
  int rejected_ = 0;
  int break_streams_after_ = 0;
  int hold_until_received_ = 0;
  int rollback_on_break_ = -1;
  int refuse_first_stream_after_ = 0;
  int streams_opened_ = 0;
  grpc::StatusCode session_calls_fail_ = grpc::StatusCode::OK;
  v1::CreateSessionRequest last_create_;
  v1::SuggestedControl suggestion_;
  int exploration_end_scan_ = 0;
  v1::ExplorationProgress exploration_end_;
  std::optional<v1::OccupancyGrid> grid_;
  std::optional<v1::MapSelfCheck> self_check_;
  grpc::StatusCode grid_answer_ = grpc::StatusCode::OK;
  int localized_from_scan_ = 3;
  struct Failures {
    int times = 0;
    grpc::StatusCode code = grpc::StatusCode::UNAVAILABLE;
  };
  std::map<std::string, Failures> fail_next_;
  bool ignore_localize_ = false;
  std::map<std::string, int> calls_;
  std::optional<double> last_grid_resolution_;
  v1::ImportMapRequest last_import_;
  std::vector<double> odometry_stamps_;
  std::vector<double> scan_stamps_;
};

class FakeSlamServer {
 public:
  FakeSlamServer();
  ~FakeSlamServer();
  FakeSlamService& service() { return service_; }
  const std::string& address() const { return address_; }

 private:
  FakeSlamService service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_CLIENT_FAKE_SLAM_SERVICE_H_
