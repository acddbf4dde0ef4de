#include "server/service/live/live_publisher.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>
#include <nlohmann/json.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/service/live/live_messages.h"

namespace waymark::service::live {
namespace {

using nlohmann::json;

std::shared_ptr<const std::string> Shared(std::string text) {
  return std::make_shared<const std::string>(std::move(text));
}

double Seconds(LivePublisher::Clock::duration d) { return std::chrono::duration<double>(d).count(); }

LivePublisher::Clock::duration FromSeconds(double s) {
  return std::chrono::duration_cast<LivePublisher::Clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

LivePublisher::LivePublisher(SlamRegistry* slam, LiveHub* hub, LiveState* state,
                             const LiveOptions& options)
    : slam_(slam), hub_(hub), state_(state), options_(options) {
  sessions_channel_ = state_->Advertise("/sessions", SessionsSchema());
  recognitions_channel_ = state_->Advertise("/recognitions", RecognitionSchema());
}

void LivePublisher::Tick(Clock::time_point now) {
  if (now >= next_list_) {
    next_list_ = now + FromSeconds(options_.sessions_seconds);
    ListSessions(now);
  }
  PublishAnswers();
  for (auto& [id, session] : sessions_) {
    if (!session.resident) continue;  // another server's, or not resumed: nothing to read here
    if (session.kind == "laser") PollGrid(id, session, now);
    PollTrajectory(id, session, now);
  }
  PublishRecognitions();
}

// ---------------------------------------------------------------------------------------------
// Sessions: channels advertised and withdrawn

void LivePublisher::OpenSession(const v1::Session& described) {
  Session session;
  session.kind = described.kind().empty() ? "laser" : described.kind();
  session.robot_id = described.robot_id();
  session.name = described.name();
  session.laser_pose = described.laser().laser_pose();
  const std::string prefix = absl::StrCat("/sessions/", described.session_id(), "/");
  auto add = [&](uint32_t* id, const ChannelSchema& schema) {
    const std::string topic = absl::StrCat(prefix, schema.suffix);
    *id = state_->Advertise(topic, schema);
    session.channels.push_back(*id);
    session.topics.push_back(topic);
  };
  add(&session.pose, PoseSchema());
  if (session.kind == "laser") {
    add(&session.scan, ScanSchema());
    add(&session.grid, GridSchema());
  }
  add(&session.trajectory, TrajectorySchema());
  if (session.kind == "laser") add(&session.loop_closures, LoopClosuresSchema());
  add(&session.confidence, ConfidenceSchema());
  if (session.kind == "visual") add(&session.vo, VisualFrameSchema());
  session.grid_resolution = options_.grid_resolution;
  sessions_.emplace(described.session_id(), std::move(session));
}

void LivePublisher::ListSessions(Clock::time_point) {
  absl::StatusOr<v1::ListSessionsResponse> listed = slam_->ListSessions("");
  if (!listed.ok()) {
    // Said once per distinct error; the channels stay as they were until the list works again.
    const std::string error = listed.status().ToString();
    if (error != last_list_error_) spdlog::warn("live view: cannot list sessions: {}", error);
    last_list_error_ = error;
    return;
  }
  last_list_error_.clear();
  std::vector<std::string> open;
  double newest = 0;
  for (const v1::Session& described : listed->sessions()) {
    if (described.state() != v1::Session::OPEN) continue;
    open.push_back(described.session_id());
    auto found = sessions_.find(described.session_id());
    if (found == sessions_.end()) {
      OpenSession(described);
      found = sessions_.find(described.session_id());
    }
    Session& session = found->second;
    session.resident = described.resident();
    session.scans_processed = described.scans_processed();
    // The map may have changed without an answer reaching the hub (nobody watched until now).
    session.progress = std::max(session.progress, described.scans_processed());
    session.stamp = std::max(session.stamp, described.last_scan_stamp());
    newest = std::max(newest, described.last_scan_stamp());
  }
  std::vector<uint32_t> withdrawn;
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    if (std::find(open.begin(), open.end(), it->first) == open.end()) {
      withdrawn.insert(withdrawn.end(), it->second.channels.begin(), it->second.channels.end());
      it = sessions_.erase(it);
    } else {
      ++it;
    }
  }
  state_->Unadvertise(withdrawn);
  hub_->Retain(open);
  PublishSessionList(newest);
}

void LivePublisher::PublishSessionList(double stamp) {
  json sessions = json::array();
  for (const auto& [id, session] : sessions_) {
    sessions.push_back({{"session_id", id},
                        {"robot_id", session.robot_id},
                        {"name", session.name},
                        {"kind", session.kind},
                        {"scans_processed", session.scans_processed},
                        {"resident", session.resident},
                        {"topics", session.topics}});
  }
  const double whole = std::max(0.0, stamp);
  json message = {{"timestamp",
                   {{"sec", static_cast<int64_t>(whole)},
                    {"nsec", static_cast<int64_t>((whole - static_cast<int64_t>(whole)) * 1e9)}}},
                  {"sessions", std::move(sessions)}};
  state_->Publish(sessions_channel_, StampNanos(stamp),
                  Shared(message.dump(-1, ' ', false, json::error_handler_t::replace)));
}

// ---------------------------------------------------------------------------------------------
// Answers: the newest of each session since the last round

void LivePublisher::PublishAnswers() {
  for (const std::string& id : hub_->SessionsWithNews()) {
    LiveHub::Latest latest = hub_->Take(id);
    if (!latest.update.has_value()) continue;
    const auto found = sessions_.find(id);
    if (found == sessions_.end()) continue;  // not listed as open yet: the next round has it
    Session& session = found->second;
    const v1::SlamUpdate& update = *latest.update;
    const uint64_t time = StampNanos(update.stamp());
    session.stamp = update.stamp();
    session.progress = update.scans_processed();
    session.scans_processed = update.scans_processed();
    if (state_->Subscribed(session.pose)) {
      state_->Publish(session.pose, time, Shared(PoseJson(update)));
    }
    if (session.scan != 0 && latest.scan.has_value() && state_->Subscribed(session.scan)) {
      state_->Publish(session.scan, time,
                      Shared(ScanJson(*latest.scan, update.pose(), session.laser_pose)));
    }
    if (state_->Subscribed(session.confidence)) {
      state_->Publish(session.confidence, time, Shared(ConfidenceJson(update)));
    }
    if (session.loop_closures != 0 && update.loop_closures() != session.loop_closures_sent) {
      // Latched even when nobody watches: the count is news once.
      state_->Publish(session.loop_closures, time,
                      Shared(LoopClosuresJson(update, session.loop_closures_sent)));
      session.loop_closures_sent = update.loop_closures();
    }
    if (session.vo != 0 && update.has_visual() && state_->Subscribed(session.vo)) {
      state_->Publish(session.vo, time, Shared(VisualFrameJson(update)));
    }
  }
}

void LivePublisher::PublishRecognitions() {
  for (const LiveHub::Recognition& r : hub_->TakeRecognitions()) {
    const double now_s = std::chrono::duration<double>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
    const double stamp = r.response.stamp() > 0 ? r.response.stamp() : now_s;
    state_->Publish(recognitions_channel_, StampNanos(stamp),
                    Shared(RecognitionJson(r.database, r.response, now_s)));
  }
}

// ---------------------------------------------------------------------------------------------
// Grids and trajectories: read from the session at a bounded rate, only when watched

void LivePublisher::PollGrid(const std::string& id, Session& session, Clock::time_point now) {
  if (session.grid_refused || now < session.next_grid || session.grid_progress == session.progress ||
      !state_->Subscribed(session.grid)) {
    return;
  }
  const Clock::time_point start = Clock::now();
  absl::StatusOr<v1::OccupancyGrid> grid = slam_->GetOccupancyGrid(id, session.grid_resolution);
  const double took = Seconds(Clock::now() - start);
  grid_render_seconds_.store(grid_render_seconds_.load() + took);
  ++grids_rendered_;
  // At most once per grid_seconds, and the session's engine held at most grid_duty of the time.
  session.next_grid =
      now + FromSeconds(std::max(options_.grid_seconds, took / std::max(options_.grid_duty, 1e-3)));
  if (!grid.ok()) {
    if (grid.status().code() == absl::StatusCode::kResourceExhausted &&
        session.grid_resolution < 1.0) {
      session.grid_resolution = std::min(1.0, session.grid_resolution * 2);
      return;
    }
    if (grid.status().code() == absl::StatusCode::kFailedPrecondition) {
      session.grid_refused = true;
      state_->BroadcastStatus(1, absl::StrCat("/sessions/", id, "/grid: ",
                                              grid.status().message()));
    }
    return;
  }
  session.grid_progress = session.progress;
  if (static_cast<size_t>(grid->width()) * grid->height() > options_.max_grid_cells &&
      session.grid_resolution < 1.0) {
    session.grid_resolution = std::min(1.0, session.grid_resolution * 2);  // from the next one
  }
  if (grid->width() == 0 || grid->height() == 0) return;  // nothing mapped yet
  state_->Publish(session.grid, StampNanos(session.stamp), Shared(GridJson(*grid, session.stamp)));
}

void LivePublisher::PollTrajectory(const std::string& id, Session& session,
                                   Clock::time_point now) {
  if (now < session.next_trajectory || session.trajectory_progress == session.progress ||
      !state_->Subscribed(session.trajectory)) {
    return;
  }
  const Clock::time_point start = Clock::now();
  absl::StatusOr<v1::Trajectory> trajectory = slam_->GetTrajectory(id);
  const double took = Seconds(Clock::now() - start);
  session.next_trajectory = now + FromSeconds(std::max(
                                      options_.trajectory_seconds,
                                      took / std::max(options_.grid_duty, 1e-3)));
  if (!trajectory.ok()) return;
  session.trajectory_progress = session.progress;
  state_->Publish(session.trajectory, StampNanos(session.stamp),
                  Shared(TrajectoryJson(*trajectory, session.stamp,
                                        options_.max_trajectory_poses)));
}

}  // namespace waymark::service::live
