#include "tests/client/fake_slam_service.h"

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

#include <cmath>
#include <condition_variable>
#include <deque>
#include <optional>
#include <thread>

namespace waymark::testing {
namespace {

grpc::Status NoSession(const std::string& id) {
  return grpc::Status(grpc::StatusCode::NOT_FOUND, "no session '" + id + "'");
}

v1::SlamUpdate Rejection(uint64_t sequence, int code, const std::string& message) {
  v1::SlamUpdate update;
  update.set_sequence(sequence);
  update.mutable_rejection()->set_code(code);
  update.mutable_rejection()->set_message(message);
  return update;
}

}  // namespace

int FakeSlamService::max_outstanding_scans() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return max_outstanding_;
}
int FakeSlamService::scans_received() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scans_received_;
}
int FakeSlamService::odometry_received() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return odometry_received_;
}
int FakeSlamService::rejected() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return rejected_;
}
void FakeSlamService::set_suggestion(const v1::SuggestedControl& suggestion) {
  std::lock_guard<std::mutex> lock(mutex_);
  suggestion_ = suggestion;
}
void FakeSlamService::set_exploration_end(int scan, v1::ExplorationProgress::State state,
                                          const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  exploration_end_scan_ = scan;
  exploration_end_.set_state(state);
  exploration_end_.set_reason(reason);
}
std::vector<double> FakeSlamService::odometry_stamps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return odometry_stamps_;
}
std::vector<double> FakeSlamService::scan_stamps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scan_stamps_;
}
v1::CreateSessionRequest FakeSlamService::last_create() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_create_;
}

grpc::Status FakeSlamService::CreateSession(grpc::ServerContext*,
                                            const v1::CreateSessionRequest* request,
                                            v1::Session* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_create_ = *request;
  if (!request->has_visual() && request->laser().laser().beam_count() == 0) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "laser geometry has no beams");
  }
  const std::string& map_id = request->laser().localize().map_session_id();
  if (!map_id.empty()) {
    auto map = sessions_.find(map_id);
    if (map == sessions_.end()) return NoSession(map_id);
    if (map->second.info.state() != v1::Session::CLOSED) {
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                          "fake: map session '" + map_id + "' is not closed");
    }
  }
  const std::string id = "s" + std::to_string(next_id_++);
  SessionData& session = sessions_[id];
  session.localizing = !map_id.empty() && !ignore_localize_;
  session.info.set_session_id(id);
  session.info.set_robot_id(request->robot_id());
  session.info.set_name(request->name());
  session.info.set_state(v1::Session::OPEN);
  *session.info.mutable_laser() = request->laser();
  session.info.set_kind(request->has_visual() ? "visual" : "laser");
  session.info.set_resident(true);
  session.trajectory.set_session_id(id);
  session.map.set_session_id(id);
  *response = session.info;
  return grpc::Status::OK;
}

v1::StreamStart FakeSlamService::StartOf(const SessionData& session) {
  v1::StreamStart start;
  start.set_from_checkpoint(session.resumed_from_checkpoint);
  start.set_scans_processed(session.info.scans_processed());
  start.set_last_scan_stamp(session.info.last_scan_stamp());
  start.set_checkpoint_at_unix(session.resumed_from_checkpoint ? 1 : 0);
  return start;
}

void FakeSlamService::RollBack(SessionData& session, int scans) {
  if (scans < 0 || scans >= session.trajectory.poses_size()) return;
  session.trajectory.mutable_poses()->DeleteSubrange(scans,
                                                     session.trajectory.poses_size() - scans);
  session.info.set_scans_processed(static_cast<uint64_t>(scans));
  const double stamp = scans > 0 ? session.trajectory.poses(scans - 1).stamp() : 0;
  session.info.set_last_scan_stamp(stamp);
  session.last_scan_stamp = scans > 0 ? stamp : -1e300;
  session.last_odometry_stamp = session.last_scan_stamp;
  session.resumed_from_checkpoint = true;
}

v1::SlamUpdate FakeSlamService::Process(SessionData& session, const v1::SensorData& message) {
  v1::SlamUpdate update;
  const uint64_t n = session.info.scans_processed() + 1;
  session.info.set_scans_processed(n);
  update.set_sequence(message.sequence());
  update.set_scans_processed(n);
  if (message.has_frame()) {
    const double stamp = message.frame().stamp();
    session.last_scan_stamp = stamp;
    session.info.set_last_scan_stamp(stamp);
    v1::TrajectoryPose* pose = session.trajectory.add_poses();
    pose->set_stamp(stamp);
    pose->mutable_pose3d()->set_x(stamp);
    pose->mutable_pose3d()->set_qw(1);
    update.set_stamp(stamp);
    *update.mutable_pose3d() = pose->pose3d();
    update.mutable_visual()->set_state(v1::VisualFrameInfo::TRACKING);
    update.mutable_visual()->mutable_counts()->set_total(100);
    update.mutable_visual()->mutable_counts()->set_tracked(80);
    return update;
  }
  const v1::LaserScan& scan = message.scan();
  session.last_scan_stamp = scan.stamp();
  v1::TrajectoryPose* pose = session.trajectory.add_poses();
  pose->set_stamp(scan.stamp());
  *pose->mutable_pose() = session.odometry;
  if (n % kScansPerSegment == 1) {
    v1::MapSegment* segment = session.map.add_segments();
    segment->set_id(n);
    *segment->mutable_frame() = session.odometry;
    segment->set_left(-0.5);
    segment->set_right(1.0 + 0.1 * (n % 3));
    segment->set_left_type(n % 2 ? v1::MapSegment::REAL : v1::MapSegment::VIRTUAL);
    segment->set_right_type(n % 3 ? v1::MapSegment::REAL : v1::MapSegment::VIRTUAL);
    session.map.set_map_revision(session.map.map_revision() + 1);
  }
  session.info.set_segments(session.map.segments_size());
  session.info.set_last_scan_stamp(scan.stamp());
  update.set_stamp(scan.stamp());
  *update.mutable_pose() = session.odometry;
  update.set_segments(session.map.segments_size());
  update.set_map_revision(session.map.map_revision());
  update.mutable_timings()->set_total_ms(0.5);
  update.set_covariance_trace_mean(0.001 * n);
  if (suggestion_.behaviour() != v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED) {
    *update.mutable_suggestion() = suggestion_;
  }
  if (exploration_end_scan_ > 0 && n >= static_cast<uint64_t>(exploration_end_scan_)) {
    *update.mutable_exploration() = exploration_end_;
    update.mutable_suggestion()->Clear();
    update.mutable_suggestion()->set_behaviour(v1::SuggestedControl::FINISHED);
    update.mutable_suggestion()->set_duration(suggestion_.duration());
  } else if (exploration_end_scan_ > 0) {
    update.mutable_exploration()->set_state(v1::ExplorationProgress::EXPLORING);
    update.mutable_exploration()->set_open_boundary(0.5);
    update.mutable_exploration()->set_targets_left(2);
  }
  if (session.localizing) {
    const bool localized = n >= static_cast<uint64_t>(localized_from_scan_);
    if (localized) ++session.fixes;
    update.mutable_localization()->set_localized(localized);
    update.mutable_localization()->set_fixes(session.fixes);
    update.mutable_localization()->set_score(localized ? 0.8 : 0.0);
    // Before the fix another place fits as well (a twin room 12 m away); the fix is unique.
    update.mutable_localization()->set_state(localized ? v1::LocalizationStatus::TRACKING
                                                       : v1::LocalizationStatus::AMBIGUOUS);
    update.mutable_localization()->set_rival_ratio(localized ? 0.5 : 0.97);
    update.mutable_localization()->set_rival_distance(12.0);
  }
  return update;
}

grpc::Status FakeSlamService::StreamSensorData(
    grpc::ServerContext*, grpc::ServerReaderWriter<v1::SlamUpdate, v1::SensorData>* stream) {
  std::mutex queue_mutex;  // guards queue, done, outstanding, received
  std::condition_variable queue_changed;
  std::deque<v1::SensorData> queue;
  bool done = false;
  int outstanding = 0;
  int received = 0;  // messages read from the stream
  std::mutex write_mutex;  // one Write at a time
  std::optional<v1::StreamStart> start;  // for the first answer, under write_mutex
  auto write = [&](const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(write_mutex);
    if (!start) {
      stream->Write(update);
      return;
    }
    v1::SlamUpdate first = update;
    *first.mutable_stream_start() = *start;
    start.reset();
    stream->Write(first);
  };

  v1::SensorData first;
  if (!stream->Read(&first)) return grpc::Status::OK;
  const std::string session_id = first.session_id();
  int break_after = 0;
  int hold_until = 0;
  int rollback = -1;
  int refuse_after = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (sessions_.count(session_id) == 0) return NoSession(session_id);
    ++streams_opened_;
    if (streams_opened_ == 1) refuse_after = refuse_first_stream_after_;
    break_after = break_streams_after_;
    hold_until = hold_until_received_;
    rollback = rollback_on_break_;
    start = StartOf(sessions_[session_id]);
  }
  if (first.payload_case() == v1::SensorData::PAYLOAD_NOT_SET) {  // a hello
    v1::SlamUpdate hello;
    hello.set_sequence(first.sequence());
    write(hello);
    if (!stream->Read(&first)) return grpc::Status::OK;
  }
  int scans_in_stream = 0;
  int refusable_in_stream = 0;
  bool broken = false;

  std::thread worker([&] {
    while (true) {
      v1::SensorData message;
      {
        std::unique_lock<std::mutex> lock(queue_mutex);
        queue_changed.wait(lock, [&] { return done || (!queue.empty() && received >= hold_until); });
        if (queue.empty()) return;
        message = std::move(queue.front());
        queue.pop_front();
      }
      const bool answered = message.has_scan() || message.has_frame();
      if (answered) std::this_thread::sleep_for(absl::ToChronoNanoseconds(scan_delay_));
      v1::SlamUpdate update;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        SessionData& session = sessions_[session_id];
        if (message.has_odometry()) {
          if (!(message.odometry().stamp() > session.last_odometry_stamp)) {
            ++rejected_;
            update = Rejection(message.sequence(), 3, "odometry stamp does not increase");
          } else {
            session.last_odometry_stamp = message.odometry().stamp();
            session.odometry = message.odometry().pose();
            continue;  // odometry is answered only when rejected
          }
        } else {
          const double stamp =
              message.has_frame() ? message.frame().stamp() : message.scan().stamp();
          const v1::LaserScan& scan = message.scan();
          if (!(stamp > session.last_scan_stamp)) {
            ++rejected_;
            update = Rejection(message.sequence(), 3,
                               message.has_frame() ? "frame stamp does not increase"
                                                   : "scan stamp does not increase");
          } else if (scan.geometry().beam_count() != 0 &&
                     scan.geometry().beam_count() != static_cast<uint32_t>(scan.ranges_size())) {
            ++rejected_;
            update = Rejection(message.sequence(), 3, "beam count disagrees with the ranges");
          } else {
            update = Process(session, message);
          }
        }
        if (update.has_rejection()) {
          session.info.set_messages_rejected(session.info.messages_rejected() + 1);
        }
      }
      if (answered) {
        std::lock_guard<std::mutex> lock(queue_mutex);
        --outstanding;  // before the answer leaves, so the client can never see it early
      }
      write(update);
    }
  });

  v1::SensorData message = std::move(first);
  do {
    const bool answered = message.has_scan() || message.has_frame();
    if (answered && break_after > 0 && ++scans_in_stream > break_after) {
      broken = true;  // like a server that dies: this scan is never answered
      break;
    }
    if (answered && refuse_after > 0 && ++refusable_in_stream > refuse_after) {
      write(Rejection(message.sequence(), 14, "fake: the server is shutting down"));
      continue;
    }
    std::unique_lock<std::mutex> lock(queue_mutex);
    if (++received == hold_until) queue_changed.notify_all();  // the worker may start
    if (answered || message.has_odometry()) {
      std::lock_guard<std::mutex> stats_lock(mutex_);
      if (answered) {
        ++scans_received_;
        scan_stamps_.push_back(message.has_frame() ? message.frame().stamp()
                                                   : message.scan().stamp());
      }
      if (message.has_odometry()) {
        ++odometry_received_;
        odometry_stamps_.push_back(message.odometry().stamp());
      }
    }
    if (static_cast<int>(queue.size()) >= queue_capacity_) {
      lock.unlock();
      {
        std::lock_guard<std::mutex> stats_lock(mutex_);
        ++rejected_;
        SessionData& session = sessions_[session_id];
        session.info.set_messages_rejected(session.info.messages_rejected() + 1);
        session.info.set_messages_dropped(session.info.messages_dropped() + 1);
      }
      write(Rejection(message.sequence(), 8, "session queue full"));
      continue;
    }
    if (answered) {
      ++outstanding;
      std::lock_guard<std::mutex> stats_lock(mutex_);
      max_outstanding_ = std::max(max_outstanding_, outstanding);
    }
    queue.push_back(std::move(message));
    queue_changed.notify_all();
  } while (stream->Read(&message));
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    done = true;
  }
  queue_changed.notify_all();
  worker.join();
  if (broken) {
    std::lock_guard<std::mutex> lock(mutex_);
    RollBack(sessions_[session_id], rollback);
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "fake: stream broken on purpose");
  }
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::GetMap(grpc::ServerContext*, const v1::GetMapRequest* request,
                                     v1::SegmentMap* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (session_calls_fail_ != grpc::StatusCode::OK) {
    return grpc::Status(session_calls_fail_, "fake: session calls fail on purpose");
  }
  auto it = sessions_.find(request->session_id());
  if (it == sessions_.end()) return NoSession(request->session_id());
  *response = it->second.map;
  if (self_check_ && !it->second.localizing) *response->mutable_self_check() = *self_check_;
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::GetTrajectory(grpc::ServerContext*,
                                            const v1::GetTrajectoryRequest* request,
                                            v1::Trajectory* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (session_calls_fail_ != grpc::StatusCode::OK) {
    return grpc::Status(session_calls_fail_, "fake: session calls fail on purpose");
  }
  auto it = sessions_.find(request->session_id());
  if (it == sessions_.end()) return NoSession(request->session_id());
  *response = it->second.trajectory;
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::CloseSession(grpc::ServerContext*,
                                           const v1::CloseSessionRequest* request,
                                           v1::Session* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (session_calls_fail_ != grpc::StatusCode::OK) {
    return grpc::Status(session_calls_fail_, "fake: session calls fail on purpose");
  }
  auto it = sessions_.find(request->session_id());
  if (it == sessions_.end()) return NoSession(request->session_id());
  if (it->second.info.state() == v1::Session::CLOSED) {
    return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                        "SLAM session \"" + request->session_id() + "\" is already closed");
  }
  it->second.info.set_state(v1::Session::CLOSED);
  it->second.info.set_resident(false);
  if (self_check_ && !it->second.localizing) {
    *it->second.info.mutable_self_check() = *self_check_;
    it->second.info.mutable_self_check()->clear_contradicting_cells();
  }
  *response = it->second.info;
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::DeleteSession(grpc::ServerContext*,
                                            const v1::DeleteSessionRequest* request,
                                            v1::DeleteSessionResponse* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(request->session_id());
  if (it == sessions_.end()) return NoSession(request->session_id());
  if (it->second.info.state() == v1::Session::OPEN) {
    if (!request->force()) {
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                          "fake: session '" + request->session_id() + "' is open");
    }
    it->second.info.set_state(v1::Session::CLOSED);
    response->set_closed_first(true);
  }
  *response->mutable_session() = it->second.info;
  response->set_trajectory_poses(static_cast<uint64_t>(it->second.trajectory.poses_size()));
  sessions_.erase(it);
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::CountCall(const std::string& method) {
  ++calls_[method];
  Failures& failures = fail_next_[method];
  if (failures.times <= 0) return grpc::Status::OK;
  --failures.times;
  return grpc::Status(failures.code, "fake: injected failure");
}

grpc::Status FakeSlamService::GetOccupancyGrid(grpc::ServerContext*,
                                               const v1::GetOccupancyGridRequest* request,
                                               v1::OccupancyGrid* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (grpc::Status injected = CountCall("GetOccupancyGrid"); !injected.ok()) return injected;
  if (session_calls_fail_ != grpc::StatusCode::OK) {
    return grpc::Status(session_calls_fail_, "fake: session calls fail on purpose");
  }
  if (grid_answer_ != grpc::StatusCode::OK) {
    return grpc::Status(grid_answer_, "fake: GetOccupancyGrid answers this on purpose");
  }
  last_grid_resolution_.reset();
  if (request->has_resolution()) last_grid_resolution_ = request->resolution();
  auto it = sessions_.find(request->session_id());
  if (it == sessions_.end()) return NoSession(request->session_id());
  if (it->second.imported) {
    *response = *it->second.imported;
  } else if (grid_) {
    *response = *grid_;
  } else {
    return grpc::Status(
        grpc::StatusCode::FAILED_PRECONDITION,
        "fake: session '" + request->session_id() + "' keeps no scans (loop closure off)");
  }
  response->set_session_id(request->session_id());
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::ImportMap(grpc::ServerContext*, const v1::ImportMapRequest* request,
                                        v1::Session* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (grpc::Status injected = CountCall("ImportMap"); !injected.ok()) return injected;
  last_import_ = *request;
  const v1::OccupancyGrid& grid = request->grid();
  if (grid.width() == 0 || grid.height() == 0 ||
      grid.cells().size() != static_cast<size_t>(grid.width()) * grid.height() ||
      !(grid.resolution() > 0)) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "fake: the grid does not add up");
  }
  const std::string id = "s" + std::to_string(next_id_++);
  SessionData& session = sessions_[id];
  session.info.set_session_id(id);
  session.info.set_robot_id(request->robot_id());
  session.info.set_name(request->name());
  session.info.set_state(v1::Session::CLOSED);
  session.info.set_kind("laser");
  session.trajectory.set_session_id(id);
  session.map.set_session_id(id);
  session.imported = grid;
  *response = session.info;
  return grpc::Status::OK;
}

grpc::Status FakeSlamService::ListSessions(grpc::ServerContext*,
                                           const v1::ListSessionsRequest* request,
                                           v1::ListSessionsResponse* response) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, session] : sessions_) {
    if (request->robot_id().empty() || request->robot_id() == session.info.robot_id()) {
      *response->add_sessions() = session.info;
    }
  }
  return grpc::Status::OK;
}

FakeSlamServer::FakeSlamServer() {
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service_);
  server_ = builder.BuildAndStart();
  address_ = "127.0.0.1:" + std::to_string(port);
}

FakeSlamServer::~FakeSlamServer() { server_->Shutdown(); }

}  // namespace waymark::testing
