#include "server/service/slam/slam_registry.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <deque>
#include <exception>
#include <functional>
#include <optional>
#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"
#include "server/common/stopwatch.h"
#include "server/service/runtime/grpc_status.h"
#include "server/service/slam/laser_session_engine.h"
#include "server/service/slam/map_self_check.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/slam_journal.h"
#include "server/service/slam/visual_params.h"
#include "server/service/slam/visual_session_engine.h"

namespace waymark::service {

using ::waymark::MsSince;
using Clock = std::chrono::steady_clock;

// One accepted message, converted to engine types at admission.
struct QueuedMessage {
  uint64_t sequence = 0;
  bool is_scan = false;  // answered: a scan or a frame
  double stamp = 0;
  size_t bytes = 0;
  std::unique_ptr<EngineInput> input;
  Clock::time_point accepted;
  int64_t journal_seq = 0;     // the session's journal seq (1, 2, 3, ...)
  uint64_t journal_ticket = 0;  // SlamJournal::WaitStored before processing; 0 = no journal
  size_t journal_bytes = 0;     // the stored message's size
};

struct SlamRegistry::Session {
  // Fixed at creation or load.
  std::string id;
  std::string robot_id;
  std::string name;
  std::string kind;  // "laser" or "visual"
  double created_at = 0;

  // Admission and queue. Lock order: registry mutex_ -> mu; never mu and engine_mu together.
  std::mutex mu;
  std::condition_variable idle_cv;  // queue empty and nothing in flight
  std::deque<QueuedMessage> queue;
  size_t queued_bytes = 0;  // decoded frames waiting (visual sessions)
  bool scheduled = false;  // on the run queue or being run by a worker
  bool in_flight = false;  // a worker holds a popped message
  bool stream_attached = false;
  // The attached stream has stopped accepting (its client half-closed, cancelled or vanished):
  // the next stream takes the session over once the queue is idle (OpenStream).
  bool stream_stopping = false;
  uint64_t stream_epoch = 0;  // counts the streams attached so far; the attached one's number
  std::function<void()> stream_cancel;  // ends the attached stream's call (OpenStream's takeover)
  bool closed = false;  // closing or closed: no stream, no message
  // Set when another server took the session's lease over: what every message is answered.
  std::optional<absl::Status> lost;
  SlamUpdateSink sink;
  std::optional<double> accepted_scan_stamp;
  std::optional<double> accepted_odometry_stamp;
  int64_t journal_last = 0;  // journal seq of the last accepted message
  uint64_t rejected = 0;
  uint64_t dropped = 0;

  // The engine and what goes with it; the strand (one worker at a time) mutates, readers and
  // checkpoints take the lock briefly.
  std::mutex engine_mu;
  std::unique_ptr<SessionEngine> engine;  // fixed once the session is built
  int64_t scans_processed = 0;
  uint64_t map_revision = 0;
  int segments = 0;
  std::optional<double> processed_scan_stamp;
  std::optional<double> processed_odometry_stamp;
  bool dirty = false;  // processed work not in the last checkpoint
  int scans_since_checkpoint = 0;
  int64_t journal_processed = 0;  // journal seq of the last processed message
  size_t journal_bytes_since_checkpoint = 0;
  Clock::time_point last_checkpoint = Clock::now();
  double updated_at = 0;
  double checkpoint_at = 0;

  // Serializes checkpoint writes; guards stored_poses and finalized.
  std::mutex checkpoint_mu;
  int64_t stored_poses = 0;  // trajectory poses already in the store
  bool finalized = false;    // closed in the store: no more checkpoints
};

namespace {

double UnixNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A session id (the client's, or a map session it names) in a message: valid UTF-8, escaped,
// and whole up to the 128 characters CheckId allows (issue 35: server/common/quote.h).
std::string Quoted(const std::string& s) { return QuoteClientText(s, 128); }

std::string NewSessionId() {
  std::random_device device;
  uint64_t words[2];
  for (uint64_t& word : words) {
    word = (static_cast<uint64_t>(device()) << 32) ^ static_cast<uint64_t>(device());
  }
  char text[33];
  std::snprintf(text, sizeof(text), "%016" PRIx64 "%016" PRIx64, words[0], words[1]);
  return text;
}

absl::Status NotFound(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("SLAM session ", Quoted(id), " not found"));
}

absl::Status ClosedError(const std::string& id) {
  return absl::FailedPreconditionError(
      absl::StrCat("SLAM session ", Quoted(id),
                   " is closed; its map and trajectory can still be read (GetMap, GetTrajectory), "
                   "create a new session to go on mapping"));
}

absl::Status CheckId(const std::string& id) {
  if (id.empty()) return absl::InvalidArgumentError("session_id is empty");
  if (id.size() > 128) {
    return absl::InvalidArgumentError(
        absl::StrCat("session_id is ", id.size(), " characters long; ids have 32"));
  }
  return absl::OkStatus();
}

v1::Session::State ToProtoState(storage::SlamSessionState state) {
  return state == storage::SlamSessionState::kClosed ? v1::Session::CLOSED : v1::Session::OPEN;
}

v1::SlamUpdate Rejection(uint64_t sequence, const absl::Status& status) {
  v1::SlamUpdate update;
  update.set_sequence(sequence);
  update.mutable_rejection()->set_code(static_cast<int32_t>(status.code()));
  update.mutable_rejection()->set_message(BoundedStatusMessage(status.message()));
  return update;
}

absl::Status ResumeError(const absl::Status& status) {
  return absl::Status(status.code(),
                      absl::StrCat("cannot resume from its checkpoint: ", status.message()));
}

// Builds the engine of a session from its stored config: new, or resumed from a checkpoint and the
// stored trajectory. Errors say what failed, without the session id.
// Finds the map a localization session localizes on, by the map session's id.
using MapLoader = std::function<absl::StatusOr<LaserSessionEngine::MapPoints>(const std::string&)>;

absl::StatusOr<std::unique_ptr<SessionEngine>> BuildEngine(
    const std::string& kind, const std::string& config_bytes, const std::string* checkpoint,
    std::vector<storage::TrajectoryPoseRecord> trajectory, const MapLoader& load_map) {
  if (kind == "visual") {
    v1::VisualSlamConfig config;
    if (!config.ParseFromString(config_bytes)) {
      return absl::DataLossError("stored config is unreadable");
    }
    if (checkpoint == nullptr) {
      absl::StatusOr<std::unique_ptr<VisualSessionEngine>> engine =
          VisualSessionEngine::Create(config);
      if (!engine.ok()) return engine.status();
      return std::unique_ptr<SessionEngine>(*std::move(engine));
    }
    absl::StatusOr<std::unique_ptr<VisualSessionEngine>> engine =
        VisualSessionEngine::Resume(config, *checkpoint, std::move(trajectory));
    if (!engine.ok()) return ResumeError(engine.status());
    return std::unique_ptr<SessionEngine>(*std::move(engine));
  }
  if (kind != "laser") {
    return absl::DataLossError(absl::StrCat("unknown session kind ", Quoted(kind)));
  }
  v1::LaserSlamConfig config;
  if (!config.ParseFromString(config_bytes)) {
    return absl::DataLossError("stored config is unreadable");
  }
  if (absl::StatusOr<LaserSessionOptions> options = ToLaserSessionOptions(config); !options.ok()) {
    return absl::DataLossError(
        absl::StrCat("stored config is invalid: ", options.status().message()));
  }
  LaserSessionEngine::MapPoints map;
  if (config.has_localize()) {
    absl::StatusOr<LaserSessionEngine::MapPoints> loaded =
        load_map(config.localize().map_session_id());
    if (!loaded.ok()) return loaded.status();
    map = *std::move(loaded);
  }
  if (checkpoint == nullptr) {
    absl::StatusOr<std::unique_ptr<LaserSessionEngine>> engine =
        LaserSessionEngine::Create(config, map);
    if (!engine.ok()) return engine.status();
    return std::unique_ptr<SessionEngine>(*std::move(engine));
  }
  absl::StatusOr<std::unique_ptr<LaserSessionEngine>> engine =
      LaserSessionEngine::FromCheckpoint(config, *checkpoint, trajectory, map);
  if (!engine.ok()) return ResumeError(engine.status());
  return std::unique_ptr<SessionEngine>(*std::move(engine));
}

// The config part of a Session for a session that is not in memory.
void DescribeStoredConfig(const storage::SlamSessionRecord& record, v1::Session* out) {
  out->set_kind(record.kind);
  if (record.kind == "visual") {
    v1::VisualSlamConfig config;
    if (config.ParseFromString(record.config)) *out->mutable_visual() = EchoVisualConfig(config);
  } else if (!out->mutable_laser()->ParseFromString(record.config)) {
    out->clear_laser();
  }
}

absl::Status OrderError(const char* sensor, double stamp, double previous) {
  return absl::InvalidArgumentError(absl::StrCat(
      sensor, " stamp ", stamp, stamp == previous ? " repeats" : " is before",
      " the previous accepted ", sensor, " stamp ", previous,
      "; each sensor's stamps must strictly increase (message ignored, session unchanged)"));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Stream

SlamRegistry::Stream::~Stream() { Close(); }

const std::string& SlamRegistry::Stream::session_id() const { return session_->id; }

absl::Status SlamRegistry::Stream::Submit(const v1::SensorData& data) {
  if (stopped_) return absl::FailedPreconditionError("the stream is closed");
  return registry_->Submit(session_, epoch_, data);
}

void SlamRegistry::Stream::StopAccepting() {
  if (stopped_) return;
  stopped_ = true;
  std::lock_guard<std::mutex> lock(session_->mu);
  if (session_->stream_epoch == epoch_) session_->stream_stopping = true;
  // A stream waiting to take over (OpenStream) may be able to at once: the queue may be idle.
  session_->idle_cv.notify_all();
}

void SlamRegistry::Stream::Close() {
  if (closed_) return;
  StopAccepting();
  closed_ = true;
  WaitIdle(*session_);
  std::lock_guard<std::mutex> lock(session_->mu);
  if (session_->stream_epoch != epoch_) return;  // another stream has taken the session over
  session_->sink = nullptr;
  session_->stream_cancel = nullptr;
  session_->stream_attached = false;
  session_->stream_stopping = false;
  session_->idle_cv.notify_all();
}

// ---------------------------------------------------------------------------------------------
// Registry

absl::StatusOr<std::unique_ptr<SlamRegistry>> SlamRegistry::Create(
    std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options) {
  if (store == nullptr) return absl::InvalidArgumentError("no SLAM store");
  if (options.queue_capacity < 1 || options.queue_capacity > 100000) {
    return absl::InvalidArgumentError(absl::StrCat("SLAM queue capacity must be in [1, 100000], got ",
                                                   options.queue_capacity));
  }
  if (options.workers < 0 || options.workers > 256) {
    return absl::InvalidArgumentError(
        absl::StrCat("SLAM workers must be in [0, 256] (0 = hardware threads), got ",
                     options.workers));
  }
  if (!std::isfinite(options.checkpoint_seconds) || options.checkpoint_seconds < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SLAM checkpoint interval must be >= 0 s (0 = off), got ", options.checkpoint_seconds));
  }
  if (options.checkpoint_scans < 0) {
    return absl::InvalidArgumentError("SLAM checkpoint scan count must be >= 0 (0 = off)");
  }
  if (options.max_sessions < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("max sessions must be at least 1, got ", options.max_sessions));
  }
  if (options.max_batch < 1) return absl::InvalidArgumentError("max_batch must be at least 1");
  if (options.max_queued_frame_bytes < 1) {
    return absl::InvalidArgumentError("max_queued_frame_bytes must be at least 1");
  }
  return std::unique_ptr<SlamRegistry>(new SlamRegistry(std::move(store), options));
}

SlamRegistry::SlamRegistry(std::unique_ptr<storage::SlamStore> store,
                           const SlamRegistryOptions& options)
    : options_(options), store_(std::move(store)), leases_(store_.get(), options.lease) {
  if (options_.journal) {
    journal_ = std::make_unique<SlamJournal>(store_.get(), [this] { return leases_.owner(); });
  }
  int workers = options_.workers;
  if (workers == 0) workers = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int i = 0; i < workers; ++i) workers_.emplace_back([this] { WorkerLoop(); });
  timer_ = std::thread([this] { TimerLoop(); });
  if (leases_.enabled()) lease_thread_ = std::thread([this] { LeaseLoop(); });
}

SlamRegistry::~SlamRegistry() {
  absl::Status status = Shutdown();
  if (!status.ok()) spdlog::error("SLAM shutdown: {}", status.ToString());
}

absl::Status SlamRegistry::CheckNewSessionRequest(const std::string& robot_id,
                                                  const std::string& name) {
  if (robot_id.empty()) {
    return absl::InvalidArgumentError("robot_id is empty: name the robot that owns the session");
  }
  if (robot_id.size() > kMaxRobotIdLength) {
    return absl::InvalidArgumentError(absl::StrCat("robot_id is ", robot_id.size(),
                                                   " bytes long; at most ", kMaxRobotIdLength));
  }
  if (name.size() > kMaxSessionNameLength) {
    return absl::InvalidArgumentError(absl::StrCat("name is ", name.size(),
                                                   " bytes long; at most ", kMaxSessionNameLength));
  }
  return absl::OkStatus();
}

absl::StatusOr<v1::Session> SlamRegistry::CreateSession(const v1::CreateSessionRequest& request) {
  if (shutting_down_) return absl::UnavailableError("the server is shutting down");
  if (absl::Status s = CheckNewSessionRequest(request.robot_id(), request.name()); !s.ok()) {
    return s;
  }
  // Exactly one kind. A request with neither is a laser session with the defaults, as it was
  // before visual sessions existed.
  if (request.has_laser() && request.has_visual()) {
    return absl::InvalidArgumentError(
        "both laser and visual configs are set: a session is either a laser or a visual session");
  }
  const bool visual = request.has_visual();
  std::string config_bytes;
  std::unique_ptr<SessionEngine> engine;
  if (visual) {
    absl::StatusOr<v1::VisualSlamConfig> config = EffectiveVisualConfig(request.visual());
    if (!config.ok()) return config.status();
    // The detector is built here, so a bad model is refused before anything is stored.
    absl::StatusOr<std::unique_ptr<VisualSessionEngine>> built =
        VisualSessionEngine::Create(*config);
    if (!built.ok()) return built.status();
    engine = *std::move(built);
    config_bytes = config->SerializeAsString();
  } else {
    absl::StatusOr<v1::LaserSlamConfig> config = EffectiveLaserConfig(request.laser());
    if (!config.ok()) return config.status();
    LaserSessionEngine::MapPoints map;
    if (config->has_localize()) {
      // The map is found (and refused with a precise error) before anything is stored.
      absl::StatusOr<LaserSessionEngine::MapPoints> loaded =
          LoadLocalizationMap(config->localize().map_session_id());
      if (!loaded.ok()) return loaded.status();
      map = *std::move(loaded);
    }
    absl::StatusOr<std::unique_ptr<LaserSessionEngine>> built =
        LaserSessionEngine::Create(*config, map);
    if (!built.ok()) return built.status();
    engine = *std::move(built);
    config_bytes = config->SerializeAsString();
  }
  return StoreNewSession(request.robot_id(), request.name(), std::move(config_bytes),
                         std::move(engine), /*close=*/false);
}

absl::StatusOr<v1::Session> SlamRegistry::ImportMap(const v1::ImportMapRequest& request) {
  if (shutting_down_) return absl::UnavailableError("the server is shutting down");
  if (absl::Status s = CheckNewSessionRequest(request.robot_id(), request.name()); !s.ok()) {
    return s;
  }
  absl::StatusOr<laser_slam::OccupancyGrid> grid = FromProtoGrid(request.grid());
  if (!grid.ok()) return grid.status();
  absl::StatusOr<v1::LaserSlamConfig> config = EffectiveLaserConfig(v1::LaserSlamConfig());
  if (!config.ok()) return config.status();
  absl::StatusOr<std::unique_ptr<LaserSessionEngine>> engine =
      LaserSessionEngine::FromImportedGrid(*config, *std::move(grid));
  if (!engine.ok()) return engine.status();
  return StoreNewSession(request.robot_id(), request.name(), config->SerializeAsString(),
                         *std::move(engine), /*close=*/true);
}

absl::StatusOr<v1::Session> SlamRegistry::StoreNewSession(const std::string& robot_id,
                                                          const std::string& name,
                                                          std::string config_bytes,
                                                          std::unique_ptr<SessionEngine> engine,
                                                          bool close) {
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  if (!close) {
    // With leases the database holds every server's sessions: count this server's own.
    absl::StatusOr<int64_t> open = store_->CountSessions(storage::SlamSessionState::kOpen);
    if (leases_.enabled()) {
      std::lock_guard<std::mutex> lock(mutex_);
      open = static_cast<int64_t>(sessions_.size());
    }
    if (!open.ok()) return open.status();
    if (*open >= options_.max_sessions) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "this server holds ", *open, " open SLAM sessions, its limit (--max-sessions ",
          options_.max_sessions, "); close finished sessions with CloseSession"));
    }
  }
  storage::SlamSessionRecord record;
  record.robot_id = robot_id;
  record.name = name;
  record.kind = engine->kind();
  record.config = std::move(config_bytes);
  absl::StatusOr<storage::SlamSessionRecord> created;
  for (int attempt = 0; attempt < 3; ++attempt) {  // a 128-bit collision is not expected
    record.id = NewSessionId();
    created = store_->CreateSession(record);
    if (!absl::IsAlreadyExists(created.status())) break;
  }
  if (!created.ok()) return created.status();
  if (!close) {
    if (absl::Status s = leases_.Take(created->id); !s.ok()) {
      (void)store_->DeleteSession(created->id);
      return s;
    }
  }
  if (close) {
    // Stored closed at once, with the engine's state as its only checkpoint.
    storage::SlamCheckpoint checkpoint;
    checkpoint.state = engine->SerializeState();
    if (absl::Status s = store_->CloseSession(created->id, checkpoint); !s.ok()) {
      (void)store_->DeleteSession(created->id);
      return s;
    }
    absl::StatusOr<storage::SlamSessionRecord> stored = store_->GetSession(created->id);
    if (!stored.ok()) return stored.status();
    return Describe(*stored, nullptr);
  }

  auto session = std::make_shared<Session>();
  session->id = created->id;
  session->robot_id = created->robot_id;
  session->name = created->name;
  session->kind = created->kind;
  session->created_at = created->created_at;
  session->updated_at = created->updated_at;
  session->engine = std::move(engine);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    sessions_[session->id] = session;
  }
  v1::Session described = Describe(*created, session.get());
  // This server holds the new session's lease: a fleet client opens its stream here at once.
  if (leases_.enabled()) described.set_served_by(leases_.address());
  return described;
}

absl::StatusOr<std::unique_ptr<SessionEngine>> SlamRegistry::EngineOf(
    const storage::SlamSessionRecord& record) {
  std::vector<storage::TrajectoryPoseRecord> trajectory;
  if (!record.checkpoint.empty()) {
    absl::StatusOr<std::vector<storage::TrajectoryPoseRecord>> stored =
        store_->LoadTrajectory(record.id);
    if (!stored.ok()) return stored.status();
    trajectory = *std::move(stored);
  }
  // Created but never checkpointed: nothing was processed that the store knows of.
  absl::StatusOr<std::unique_ptr<SessionEngine>> engine = BuildEngine(
      record.kind, record.config, record.checkpoint.empty() ? nullptr : &record.checkpoint,
      std::move(trajectory),
      [this](const std::string& id) { return LoadLocalizationMap(id); });
  if (!engine.ok()) {
    return absl::Status(engine.status().code(), absl::StrCat("SLAM session ", Quoted(record.id),
                                                             ": ", engine.status().message()));
  }
  return engine;
}

absl::StatusOr<std::shared_ptr<const laser_slam::PointCloud>> SlamRegistry::LoadLocalizationMap(
    const std::string& map_session_id) {
  const std::string what = absl::StrCat("map session ", Quoted(map_session_id));
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(map_session_id);
  if (absl::IsNotFound(record.status())) {
    return absl::NotFoundError(absl::StrCat(
        what, " not found: localize on a closed laser session of this server (ListSessions), or "
              "import a map first (ImportMap, `waymark slam import-map`)"));
  }
  if (!record.ok()) return record.status();
  if (record->kind != "laser") {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " is a ", record->kind, " session: it has no laser map to localize on"));
  }
  if (record->state != storage::SlamSessionState::kClosed) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " is still open for writing: close it first (CloseSession, `waymark slam close ",
        map_session_id, "`) so that its map is final"));
  }
  v1::LaserSlamConfig config;
  if (config.ParseFromString(record->config) && config.has_localize()) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " is itself a localization session: it has no map of its own; localize on ",
        Quoted(config.localize().map_session_id()), " instead"));
  }
  absl::StatusOr<std::unique_ptr<SessionEngine>> engine = EngineOf(*record);
  if (!engine.ok()) return engine.status();
  auto* laser = static_cast<LaserSessionEngine*>(engine->get());
  absl::StatusOr<laser_slam::PointCloud> points = laser->MapPointsForLocalization();
  if (!points.ok()) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " cannot be localized on: ", points.status().message()));
  }
  if (points->empty()) {
    return absl::FailedPreconditionError(absl::StrCat(what, " has no scans in its map yet"));
  }
  return std::make_shared<const laser_slam::PointCloud>(*std::move(points));
}

absl::StatusOr<std::shared_ptr<SlamRegistry::Session>> SlamRegistry::FindResident(
    const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) return NotFound(id);
  return it->second;
}

absl::StatusOr<std::shared_ptr<SlamRegistry::Session>> SlamRegistry::LoadSession(
    const storage::SlamSessionRecord& record) {
  auto session = std::make_shared<Session>();
  session->id = record.id;
  session->robot_id = record.robot_id;
  session->name = record.name;
  session->kind = record.kind;
  session->created_at = record.created_at;
  session->updated_at = record.updated_at;
  session->checkpoint_at = record.checkpoint_at;
  absl::StatusOr<std::unique_ptr<SessionEngine>> engine = EngineOf(record);
  if (!engine.ok()) return engine.status();
  session->engine = *std::move(engine);
  session->stored_poses = session->engine->trajectory_size();
  session->scans_processed = record.scans_processed;
  session->map_revision = static_cast<uint64_t>(record.map_revision);
  session->segments = record.segments;
  session->processed_scan_stamp = session->accepted_scan_stamp = record.last_scan_stamp;
  session->processed_odometry_stamp = session->accepted_odometry_stamp =
      record.last_odometry_stamp;
  session->journal_last = session->journal_processed = record.journal_through;
  if (record.state == storage::SlamSessionState::kClosed) {
    session->closed = true;
    session->finalized = true;
    return session;
  }
  if (absl::Status s = ReplayJournal(*session); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat("SLAM session ", Quoted(record.id),
                                               ": cannot replay its journal: ", s.message()));
  }
  return session;
}

absl::Status SlamRegistry::ReplayJournal(Session& session) {
  absl::StatusOr<std::vector<storage::SlamJournalEntry>> journal = store_->LoadJournal(session.id);
  if (!journal.ok()) return journal.status();
  if (journal->empty()) return absl::OkStatus();
  const Clock::time_point started = Clock::now();
  int replayed = 0;
  // The session is not shared yet: no locks. Each message was admitted and put in time order
  // when it was accepted; what the engine refused then it refuses again (it is deterministic).
  for (storage::SlamJournalEntry& entry : *journal) {
    session.journal_last = entry.seq;
    v1::SensorData data;
    if (!data.ParseFromString(entry.message)) {
      return absl::DataLossError(
          absl::StrCat("journal message ", entry.seq, " is not a waymark.v1.SensorData"));
    }
    absl::StatusOr<AdmittedMessage> admitted = session.engine->Admit(data);
    if (!admitted.ok()) {
      // Only a newer build that admits less could get here; say so and go on without it.
      spdlog::warn("SLAM session {}: journal message {} is no longer admitted: {}", session.id,
                   entry.seq, admitted.status().ToString());
      session.journal_processed = entry.seq;
      continue;
    }
    (admitted->answered ? session.accepted_scan_stamp : session.accepted_odometry_stamp) =
        admitted->stamp;
    (void)Apply(session, *admitted->input, admitted->answered, admitted->stamp, entry.seq,
                entry.message.size(), 0.0);
    ++replayed;
  }
  spdlog::info("SLAM session {}: replayed {} journaled messages after its checkpoint in {:.0f} ms",
               session.id, replayed, MsSince(started));
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<SlamRegistry::Session>> SlamRegistry::ResidentOrLoad(
    const std::string& id, bool* loaded) {
  if (loaded != nullptr) *loaded = false;
  if (auto resident = FindResident(id); resident.ok()) return resident;
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  if (auto resident = FindResident(id); resident.ok()) return resident;  // loaded meanwhile
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(id);
  if (!record.ok()) return record.status();
  if (record->state == storage::SlamSessionState::kClosed) return ClosedError(id);
  // Served by one server at a time: the one that holds the lease.
  if (absl::Status s = leases_.Take(id); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<Session>> session = LoadSession(*record);
  if (!session.ok()) return session.status();
  spdlog::info("SLAM session {} resumed from its checkpoint and journal ({} scans, {} poses)", id,
               (*session)->scans_processed, (*session)->engine->trajectory_size());
  if (loaded != nullptr) *loaded = true;
  std::lock_guard<std::mutex> lock(mutex_);
  sessions_[id] = *session;
  return *session;
}

absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> SlamRegistry::OpenStream(
    const std::string& session_id, SlamUpdateSink sink, std::function<void()> cancel) {
  if (absl::Status s = CheckId(session_id); !s.ok()) return s;
  if (shutting_down_) {
    return absl::UnavailableError("the server is shutting down; resume the session after it restarts");
  }
  bool loaded = false;
  absl::StatusOr<std::shared_ptr<Session>> session = ResidentOrLoad(session_id, &loaded);
  if (!session.ok()) return session.status();
  uint64_t epoch = 0;
  {
    Session& s = **session;
    std::unique_lock<std::mutex> lock(s.mu);
    if (s.closed) return ClosedError(session_id);
    if (s.stream_attached && !s.stream_stopping) {
      // The newest stream wins: a robot that reconnects (its Wi-Fi dropped, it restarted, it
      // cancelled its stream) gets its session at once. The old stream's connection may be
      // dead without the server knowing it for a minute (keepalive), and a stream the client
      // has just cancelled may not have noticed yet (the issue 21 campaign's reconnects were
      // refused "already has an open stream"). The old stream accepts nothing more and its call
      // is cancelled; what it accepted is still processed before the new stream attaches. The
      // callback runs under the session's lock, so the old call (which detaches under it) is
      // still there.
      s.stream_stopping = true;
      if (s.stream_cancel) s.stream_cancel();
      s.stream_cancel = nullptr;
      spdlog::info("SLAM session {}: a new stream takes over from the open one", session_id);
    }
    // The previous stream has ended: it hands the session over once the messages it accepted
    // are answered, which this waits for, briefly.
    const auto handed_over = [&s] {
      return s.closed || !s.stream_attached || (s.queue.empty() && !s.in_flight);
    };
    if (!s.idle_cv.wait_for(lock, options_.stream_handover_wait, handed_over)) {
      return absl::UnavailableError(absl::StrCat(
          "SLAM session ", Quoted(session_id), ": its previous stream has ended but the messages "
          "it sent are still being processed (", s.queue.size(), " queued); try again shortly"));
    }
    if (s.closed) return ClosedError(session_id);
    s.stream_attached = true;
    s.stream_stopping = false;
    epoch = ++s.stream_epoch;
    s.sink = std::move(sink);
    s.stream_cancel = std::move(cancel);
  }
  // The previous stream has drained the queue before it detached: this is all the session has.
  v1::StreamStart start;
  start.set_from_checkpoint(loaded);
  {
    std::lock_guard<std::mutex> lock((*session)->engine_mu);
    start.set_scans_processed(static_cast<uint64_t>((*session)->scans_processed));
    start.set_last_scan_stamp((*session)->processed_scan_stamp.value_or(0));
    start.set_checkpoint_at_unix(static_cast<int64_t>((*session)->checkpoint_at));
  }
  return std::unique_ptr<Stream>(new Stream(this, *session, epoch, std::move(start)));
}

absl::Status SlamRegistry::Submit(const std::shared_ptr<Session>& owner, uint64_t epoch,
                                  const v1::SensorData& data) {
  Session& session = *owner;
  auto reject = [&session](absl::Status status, bool dropped = false) {
    std::lock_guard<std::mutex> lock(session.mu);
    ++session.rejected;
    if (dropped) ++session.dropped;
    return status;
  };
  if (!data.session_id().empty() && data.session_id() != session.id) {
    return reject(absl::InvalidArgumentError(
        absl::StrCat("message names session ", Quoted(data.session_id()), " but this stream is on ",
                     Quoted(session.id), "; one stream serves one session")));
  }
  // The engine is fixed once the session is built, and Admit reads only its fixed part: no lock.
  absl::StatusOr<AdmittedMessage> admitted = session.engine->Admit(data);
  if (!admitted.ok()) return reject(admitted.status());
  // Serialized outside the session's lock (a camera frame's bytes); dropped if it is refused.
  std::string journal_bytes;
  if (journal_ != nullptr) journal_bytes = data.SerializeAsString();
  QueuedMessage message;
  message.sequence = data.sequence();
  message.is_scan = admitted->answered;
  message.stamp = admitted->stamp;
  message.bytes = admitted->bytes;
  message.input = std::move(admitted->input);
  const double stamp = message.stamp;

  bool schedule = false;
  {
    std::lock_guard<std::mutex> lock(session.mu);
    absl::Status refused;
    std::optional<double>& last =
        message.is_scan ? session.accepted_scan_stamp : session.accepted_odometry_stamp;
    if (session.lost.has_value()) {
      refused = *session.lost;
    } else if (shutting_down_) {
      refused = absl::UnavailableError(
          "the server is shutting down; resume the session after it restarts");
    } else if (session.closed || !session.stream_attached) {
      refused = absl::FailedPreconditionError("the session is closed");
    } else if (session.stream_epoch != epoch || session.stream_stopping) {
      // Only a taken-over stream gets here: one that stopped itself refuses in Stream::Submit.
      refused = absl::AbortedError(
          "a newer stream took this session over (the robot reconnected); this stream ends");
    } else if (last.has_value() && !(stamp > *last)) {
      refused = OrderError(admitted->sensor, stamp, *last);
    } else if (static_cast<int>(session.queue.size()) >= options_.queue_capacity) {
      ++session.dropped;
      refused = absl::ResourceExhaustedError(absl::StrCat(
          "session queue is full (", options_.queue_capacity,
          " messages waiting; message dropped): keep at most ", options_.queue_capacity,
          " messages outstanding (sent after the last answered scan) and resend this one"));
    } else if (message.bytes > 0 && session.queued_bytes > 0 &&
               session.queued_bytes + message.bytes > options_.max_queued_frame_bytes) {
      // The first frame of an empty queue always fits, whatever its size.
      ++session.dropped;
      refused = absl::ResourceExhaustedError(absl::StrCat(
          "session queue holds ", session.queue.size(), " decoded frames (",
          session.queued_bytes / (1024 * 1024), " MiB; limit ",
          options_.max_queued_frame_bytes / (1024 * 1024),
          " MiB; frame dropped): send fewer frames ahead of the answers and resend this one"));
    }
    if (!refused.ok()) {
      ++session.rejected;
      return refused;
    }
    last = stamp;
    message.accepted = Clock::now();
    // Journaled under the session's lock, so that its journal seqs are in acceptance order.
    message.journal_seq = ++session.journal_last;
    if (journal_ != nullptr) {
      message.journal_bytes = journal_bytes.size();
      message.journal_ticket = journal_->Append(
          storage::SlamJournalEntry{session.id, message.journal_seq, std::move(journal_bytes)});
    }
    session.queued_bytes += message.bytes;
    session.queue.push_back(std::move(message));
    if (!session.scheduled) {
      session.scheduled = true;
      schedule = true;
    }
  }
  // The run queue holds a shared_ptr: the session lives until its messages are processed.
  if (schedule) Schedule(owner);
  return absl::OkStatus();
}

void SlamRegistry::Schedule(std::shared_ptr<Session> session) {
  {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    run_queue_.push_back(std::move(session));
  }
  pool_cv_.notify_one();
}

void SlamRegistry::WorkerLoop() {
  while (true) {
    std::shared_ptr<Session> session;
    {
      std::unique_lock<std::mutex> lock(pool_mutex_);
      pool_cv_.wait(lock, [this] { return stop_workers_ || !run_queue_.empty(); });
      if (run_queue_.empty()) return;  // stopping and nothing left
      session = std::move(run_queue_.front());
      run_queue_.pop_front();
    }
    RunSession(session);
  }
}

void SlamRegistry::RunSession(const std::shared_ptr<Session>& session) {
  for (int i = 0; i < options_.max_batch; ++i) {
    QueuedMessage message;
    SlamUpdateSink sink;
    {
      std::lock_guard<std::mutex> lock(session->mu);
      if (session->queue.empty()) {
        session->scheduled = false;
        session->idle_cv.notify_all();
        return;
      }
      message = std::move(session->queue.front());
      session->queue.pop_front();
      session->queued_bytes -= message.bytes;
      session->in_flight = true;
      sink = session->sink;
    }
    Process(*session, message, sink);
    {
      std::lock_guard<std::mutex> lock(session->mu);
      session->in_flight = false;
      if (session->queue.empty()) {
        session->scheduled = false;
        session->idle_cv.notify_all();
        return;
      }
    }
  }
  Schedule(session);  // more waiting: go to the back of the line
}

absl::StatusOr<std::optional<v1::SlamUpdate>> SlamRegistry::Apply(Session& session,
                                                                    EngineInput& input,
                                                                    bool is_scan, double stamp,
                                                                    int64_t journal_seq,
                                                                    size_t journal_bytes,
                                                                    double queue_ms) {
  // Handled either way: a checkpoint after it includes its journal row (an engine error would
  // refuse it again on a replay).
  session.journal_processed = journal_seq;
  session.journal_bytes_since_checkpoint += journal_bytes;
  absl::StatusOr<std::optional<v1::SlamUpdate>> result;
  try {
    result = session.engine->Process(input, queue_ms);
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("the SLAM engine failed on this message: ", e.what()));
  }
  if (!result.ok()) return result.status();
  if (is_scan) {
    ++session.scans_processed;
    ++session.scans_since_checkpoint;
    session.processed_scan_stamp = stamp;
  } else {
    session.processed_odometry_stamp = stamp;
  }
  session.dirty = true;
  session.updated_at = UnixNow();
  if (result->has_value()) {
    v1::SlamUpdate& update = **result;
    update.set_scans_processed(static_cast<uint64_t>(session.scans_processed));
    if (is_scan) {
      session.map_revision = update.map_revision();
      session.segments = static_cast<int>(update.segments());
    }
  }
  return result;
}

void SlamRegistry::Process(Session& session, QueuedMessage& message, const SlamUpdateSink& sink) {
  if (options_.before_process) options_.before_process(session.id);
  // Processed (and answered) only once stored: what a client was answered survives a crash.
  absl::Status error =
      journal_ != nullptr ? journal_->WaitStored(message.journal_ticket) : absl::OkStatus();
  const double queue_ms = MsSince(message.accepted);
  std::optional<v1::SlamUpdate> answer;
  if (error.ok()) {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    absl::StatusOr<std::optional<v1::SlamUpdate>> result =
        Apply(session, *message.input, message.is_scan, message.stamp, message.journal_seq,
              message.journal_bytes, queue_ms);
    if (result.ok()) {
      answer = *std::move(result);
    } else {
      error = result.status();
    }
  } else {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    session.journal_processed = message.journal_seq;  // never stored: nothing to replay
  }
  if (answer.has_value()) answer->set_sequence(message.sequence);
  if (!error.ok()) {
    {
      std::lock_guard<std::mutex> lock(session.mu);
      ++session.rejected;
    }
    answer = Rejection(message.sequence, error);
  }
  // Observed before it goes out, so a client that has the answer can already scrape it.
  if (answer.has_value() && error.ok()) {
    std::shared_ptr<const UpdateObserver> observer;
    {
      std::lock_guard<std::mutex> lock(observer_mutex_);
      observer = observer_;
    }
    if (observer) (*observer)(session.id, *answer);
  }
  if (answer.has_value() && sink) sink(*answer);
  if (message.is_scan && error.ok()) MaybeCheckpoint(session);
}

void SlamRegistry::SetUpdateObserver(UpdateObserver observer) {
  std::lock_guard<std::mutex> lock(observer_mutex_);
  observer_ = observer ? std::make_shared<const UpdateObserver>(std::move(observer)) : nullptr;
}

void SlamRegistry::MaybeCheckpoint(Session& session) {
  bool due = false;
  {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    if (!session.dirty) return;
    due = (options_.checkpoint_scans > 0 &&
           session.scans_since_checkpoint >= options_.checkpoint_scans) ||
          (journal_ != nullptr &&
           session.journal_bytes_since_checkpoint >= options_.checkpoint_journal_bytes) ||
          (options_.checkpoint_seconds > 0 &&
           std::chrono::duration<double>(Clock::now() - session.last_checkpoint).count() >=
               options_.checkpoint_seconds);
  }
  if (!due) return;
  if (absl::Status s = Checkpoint(session, /*close=*/false); !s.ok()) {
    spdlog::warn("SLAM session {}: checkpoint failed (will retry): {}", session.id, s.ToString());
  }
}

namespace {

// The closing session's self-check as stored with its final checkpoint (a serialized
// v1::MapSelfCheck without its cells, which ListSessions shows); empty for a session without
// one. A check that fails is logged, never a reason not to close. Caller holds engine_mu.
std::string FinalMapCheck(SessionEngine& engine, const std::string& session_id) {
  v1::MapSelfCheck check;
  const absl::Status status = engine.CheckMap(&check);
  if (absl::IsFailedPrecondition(status)) return "";
  if (!status.ok()) {
    spdlog::warn("SLAM session {}: the final map's self-check failed: {}", session_id,
                 status.ToString());
    return "";
  }
  if (!check.consistent()) {
    spdlog::warn("SLAM session {}: the final map {}", session_id, check.verdict());
  }
  check.clear_contradicting_cells();
  if (check.worst_areas_size() > static_cast<int>(kMaxSessionCheckAreas)) {
    check.mutable_worst_areas()->DeleteSubrange(
        static_cast<int>(kMaxSessionCheckAreas),
        check.worst_areas_size() - static_cast<int>(kMaxSessionCheckAreas));
  }
  return check.SerializeAsString();
}

}  // namespace

absl::Status SlamRegistry::Checkpoint(Session& session, bool close) {
  std::lock_guard<std::mutex> checkpoint_lock(session.checkpoint_mu);
  if (session.finalized) return absl::OkStatus();
  storage::SlamCheckpoint checkpoint;
  int64_t trajectory_size = 0;
  {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    if (!close && !session.dirty) return absl::OkStatus();
    checkpoint.state = session.engine->SerializeState();
    checkpoint.scans_processed = session.scans_processed;
    checkpoint.map_revision = static_cast<int64_t>(session.map_revision);
    checkpoint.segments = session.segments;
    checkpoint.last_scan_stamp = session.processed_scan_stamp;
    checkpoint.last_odometry_stamp = session.processed_odometry_stamp;
    checkpoint.journal_through = session.journal_processed;
    trajectory_size = session.engine->trajectory_size();
    for (int64_t seq = session.stored_poses; seq < trajectory_size; ++seq) {
      checkpoint.new_poses.push_back(session.engine->PoseRecord(seq));
    }
    if (close) checkpoint.map_check = FinalMapCheck(*session.engine, session.id);
    session.dirty = false;
    session.scans_since_checkpoint = 0;
    session.journal_bytes_since_checkpoint = 0;
    session.last_checkpoint = Clock::now();
  }
  // Fenced: refused if another server has taken the session over.
  checkpoint.lease_owner = leases_.owner();
  absl::Status status = close ? store_->CloseSession(session.id, checkpoint)
                              : store_->WriteCheckpoint(session.id, checkpoint);
  if (!status.ok()) {
    std::lock_guard<std::mutex> lock(session.engine_mu);
    session.dirty = true;
    return status;
  }
  session.stored_poses = std::max(session.stored_poses, trajectory_size);
  if (close) session.finalized = true;
  std::lock_guard<std::mutex> lock(session.engine_mu);
  session.checkpoint_at = UnixNow();
  return absl::OkStatus();
}

void SlamRegistry::TimerLoop() {
  if (options_.checkpoint_seconds <= 0) return;
  const auto period = std::chrono::duration<double>(
      std::clamp(options_.checkpoint_seconds / 4.0, 0.05, 5.0));
  std::unique_lock<std::mutex> lock(timer_mutex_);
  while (!stop_timer_) {
    timer_cv_.wait_for(lock, period, [this] { return stop_timer_; });
    if (stop_timer_) return;
    lock.unlock();
    std::vector<std::shared_ptr<Session>> sessions;
    {
      std::lock_guard<std::mutex> map_lock(mutex_);
      for (const auto& [id, session] : sessions_) sessions.push_back(session);
    }
    for (const std::shared_ptr<Session>& session : sessions) {
      bool due = false;
      {
        std::lock_guard<std::mutex> engine_lock(session->engine_mu);
        due = session->dirty &&
              std::chrono::duration<double>(Clock::now() - session->last_checkpoint).count() >=
                  options_.checkpoint_seconds;
      }
      if (!due) continue;
      if (absl::Status s = Checkpoint(*session, false); !s.ok()) {
        spdlog::warn("SLAM session {}: checkpoint failed (will retry): {}", session->id,
                     s.ToString());
      }
    }
    lock.lock();
  }
}

void SlamRegistry::LeaseLoop() {
  const auto period =
      std::chrono::duration<double>(std::max(0.05, options_.lease.ttl_seconds / 3.0));
  std::unique_lock<std::mutex> lock(timer_mutex_);
  while (!stop_timer_) {
    timer_cv_.wait_for(lock, period, [this] { return stop_timer_; });
    if (stop_timer_) return;
    lock.unlock();
    std::vector<std::string> ids;
    {
      std::lock_guard<std::mutex> map_lock(mutex_);
      for (const auto& [id, session] : sessions_) ids.push_back(id);
    }
    for (auto& [id, moved] : leases_.Renew(ids)) {
      spdlog::warn("{}", std::string(moved.message()));
      DropLost(id, moved);
    }
    lock.lock();
  }
}

void SlamRegistry::DropLost(const std::string& session_id, const absl::Status& moved) {
  std::shared_ptr<Session> session;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sessions_.find(session_id);
    if (it == sessions_.end()) return;
    session = it->second;
    sessions_.erase(it);
  }
  {
    std::lock_guard<std::mutex> lock(session->checkpoint_mu);
    session->finalized = true;  // never written again from here: the new holder writes it
  }
  std::lock_guard<std::mutex> lock(session->mu);
  session->lost = moved;
  session->closed = true;
}

void SlamRegistry::WaitIdle(Session& session) {
  std::unique_lock<std::mutex> lock(session.mu);
  session.idle_cv.wait(lock, [&session] { return session.queue.empty() && !session.in_flight; });
}

absl::StatusOr<v1::Session> SlamRegistry::CloseSession(const std::string& session_id) {
  if (absl::Status s = CheckId(session_id); !s.ok()) return s;
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  if (absl::Status s = CloseLocked(session_id); !s.ok()) return s;
  absl::StatusOr<storage::SlamSessionRecord> closed = store_->GetSession(session_id);
  if (!closed.ok()) return closed.status();
  return Describe(*closed, nullptr);
}

absl::StatusOr<v1::DeleteSessionResponse> SlamRegistry::DeleteSession(
    const std::string& session_id, bool force) {
  if (absl::Status s = CheckId(session_id); !s.ok()) return s;
  // Held throughout: no stream can load or attach to the session between the close and the delete.
  std::lock_guard<std::mutex> load_lock(load_mutex_);
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  v1::DeleteSessionResponse response;
  if (record->state == storage::SlamSessionState::kOpen) {
    if (!force) {
      return absl::FailedPreconditionError(absl::StrCat(
          "SLAM session ", Quoted(session_id), " is open (", record->scans_processed,
          " scans at its last checkpoint): close it first (CloseSession), or delete it with "
          "force, which closes it and then deletes it"));
    }
    if (absl::Status s = CloseLocked(session_id); !s.ok()) return s;
    response.set_closed_first(true);
  }
  absl::StatusOr<storage::SlamSessionRecord> deleted = store_->DeleteSession(session_id);
  if (!deleted.ok()) return deleted.status();
  *response.mutable_session() = Describe(*deleted, nullptr);
  response.set_trajectory_poses(static_cast<uint64_t>(deleted->trajectory_length));
  spdlog::info("SLAM session {} deleted ({} scans, {} trajectory poses{})", session_id,
               deleted->scans_processed, deleted->trajectory_length,
               response.closed_first() ? ", closed first" : "");
  return response;
}

absl::Status SlamRegistry::CloseLocked(const std::string& session_id) {
  absl::StatusOr<std::shared_ptr<Session>> resident = FindResident(session_id);
  if (resident.ok()) {
    Session& session = **resident;
    {
      std::lock_guard<std::mutex> lock(session.mu);
      if (session.stream_attached) {
        return absl::FailedPreconditionError(
            absl::StrCat("SLAM session ", Quoted(session_id),
                         " has an open stream: half-close it (WritesDone) and wait for its "
                         "answers, then close the session"));
      }
      session.closed = true;
    }
    WaitIdle(session);
    {
      // The back end's last optimisation, so that the closed session keeps its final map.
      std::lock_guard<std::mutex> lock(session.engine_mu);
      session.engine->Finish();
    }
    if (absl::Status s = Checkpoint(session, /*close=*/true); !s.ok()) {
      std::lock_guard<std::mutex> lock(session.mu);
      session.closed = false;
      return s;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    sessions_.erase(session_id);
  } else {
    absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
    if (!record.ok()) return record.status();
    if (record->state == storage::SlamSessionState::kClosed) {
      return absl::FailedPreconditionError(
          absl::StrCat("SLAM session ", Quoted(session_id), " is already closed"));
    }
    // Not in memory (a server that stopped without a final checkpoint): its last checkpoint and
    // its journal are its final state, if no other server serves it.
    if (absl::Status s = leases_.Take(session_id); !s.ok()) return s;
    if (absl::StatusOr<std::shared_ptr<Session>> loaded = LoadSession(*record); loaded.ok()) {
      (*loaded)->engine->Finish();
      return Checkpoint(**loaded, /*close=*/true);
    } else {
      spdlog::warn("SLAM session {}: closing at its last checkpoint without its journal: {}",
                   session_id, loaded.status().ToString());
    }
    storage::SlamCheckpoint checkpoint;
    checkpoint.lease_owner = leases_.owner();
    checkpoint.state = record->checkpoint;
    checkpoint.scans_processed = record->scans_processed;
    checkpoint.map_revision = record->map_revision;
    checkpoint.segments = record->segments;
    checkpoint.last_scan_stamp = record->last_scan_stamp;
    checkpoint.last_odometry_stamp = record->last_odometry_stamp;
    checkpoint.journal_through = record->journal_through;
    if (absl::Status s = store_->CloseSession(session_id, checkpoint); !s.ok()) return s;
  }
  return absl::OkStatus();
}

v1::Session SlamRegistry::Describe(const storage::SlamSessionRecord& record, Session* resident) {
  v1::Session out;
  out.set_session_id(record.id);
  out.set_robot_id(record.robot_id);
  out.set_name(record.name);
  out.set_state(ToProtoState(record.state));
  if (resident != nullptr) {
    resident->engine->DescribeConfig(&out);  // fixed since creation: no lock
  } else {
    DescribeStoredConfig(record, &out);
  }
  out.set_scans_processed(static_cast<uint64_t>(record.scans_processed));
  out.set_segments(static_cast<uint32_t>(std::max(0, record.segments)));
  out.set_map_revision(static_cast<uint64_t>(record.map_revision));
  out.set_last_scan_stamp(record.last_scan_stamp.value_or(0.0));
  out.set_created_at_unix(static_cast<int64_t>(record.created_at));
  out.set_updated_at_unix(static_cast<int64_t>(record.updated_at));
  out.set_checkpoint_at_unix(static_cast<int64_t>(record.checkpoint_at));
  // This server's clock against the database's: close enough to tell a live lease from one long
  // expired, which is what an operator asks.
  if (!record.lease.owner.empty() && record.lease.expires_at > UnixNow()) {
    out.set_served_by(record.lease.address);
  }
  if (!record.map_check.empty() && !out.mutable_self_check()->ParseFromString(record.map_check)) {
    out.clear_self_check();  // written by a newer server in a form this one cannot read
  }
  if (resident != nullptr) {
    out.set_resident(true);
    {
      std::lock_guard<std::mutex> lock(resident->engine_mu);
      out.set_scans_processed(static_cast<uint64_t>(resident->scans_processed));
      out.set_segments(static_cast<uint32_t>(std::max(0, resident->segments)));
      out.set_map_revision(resident->map_revision);
      out.set_last_scan_stamp(resident->processed_scan_stamp.value_or(0.0));
      out.set_updated_at_unix(static_cast<int64_t>(resident->updated_at));
      out.set_checkpoint_at_unix(static_cast<int64_t>(resident->checkpoint_at));
    }
    std::lock_guard<std::mutex> lock(resident->mu);
    out.set_messages_rejected(resident->rejected);
    out.set_messages_dropped(resident->dropped);
    out.set_queued_messages(static_cast<uint32_t>(resident->queue.size()));
  }
  return out;
}

absl::StatusOr<v1::Session> SlamRegistry::GetSession(const std::string& session_id) {
  if (absl::Status s = CheckId(session_id); !s.ok()) return s;
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  absl::StatusOr<std::shared_ptr<Session>> resident = FindResident(session_id);
  return Describe(*record, resident.ok() ? resident->get() : nullptr);
}

absl::StatusOr<v1::ListSessionsResponse> SlamRegistry::ListSessions(const std::string& robot_id) {
  absl::StatusOr<std::vector<storage::SlamSessionRecord>> records = store_->ListSessions(robot_id);
  if (!records.ok()) return records.status();
  v1::ListSessionsResponse response;
  for (const storage::SlamSessionRecord& record : *records) {
    absl::StatusOr<std::shared_ptr<Session>> resident = FindResident(record.id);
    *response.add_sessions() = Describe(record, resident.ok() ? resident->get() : nullptr);
  }
  return response;
}

absl::StatusOr<std::shared_ptr<SlamRegistry::Session>> SlamRegistry::SessionToRead(
    const std::string& session_id, const absl::Status& visual_refusal) {
  if (absl::Status s = CheckId(session_id); !s.ok()) return s;
  if (auto resident = FindResident(session_id); resident.ok()) return *resident;
  // Not in memory (closed, or not resumed since a restart): rebuild the engine from the
  // checkpoint to read it, without making the session resident.
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  if (record->kind == "visual") return visual_refusal;  // without building a detector
  return LoadSession(*record);
}

absl::StatusOr<v1::SegmentMap> SlamRegistry::GetMap(const std::string& session_id) {
  absl::StatusOr<std::shared_ptr<Session>> session =
      SessionToRead(session_id, NoSegmentMapError());
  if (!session.ok()) return session.status();
  v1::SegmentMap map;
  map.set_session_id(session_id);
  std::lock_guard<std::mutex> lock((*session)->engine_mu);
  map.set_map_revision((*session)->map_revision);
  if (absl::Status s = (*session)->engine->FillMap(&map); !s.ok()) return s;
  // A session without a self-check (no scans kept) answers its map without one.
  if (absl::Status s = (*session)->engine->CheckMap(map.mutable_self_check());
      absl::IsFailedPrecondition(s)) {
    map.clear_self_check();
  } else if (!s.ok()) {
    return absl::Status(s.code(), absl::StrCat("SLAM session ", Quoted(session_id),
                                               ": the map's self-check: ", s.message()));
  }
  return map;
}

absl::StatusOr<v1::Trajectory> SlamRegistry::GetTrajectory(const std::string& session_id) {
  if (absl::Status s = CheckId(session_id); !s.ok()) return s;
  v1::Trajectory out;
  out.set_session_id(session_id);
  if (auto resident = FindResident(session_id); resident.ok()) {
    std::lock_guard<std::mutex> lock((*resident)->engine_mu);
    (*resident)->engine->AppendTrajectory(&out);
    return out;
  }
  absl::StatusOr<storage::SlamSessionRecord> record = store_->GetSession(session_id);
  if (!record.ok()) return record.status();
  if (record->kind == "laser") {
    // Stored laser poses are in the EKF's frame; the engine corrects them with its pose graph.
    absl::StatusOr<std::shared_ptr<Session>> loaded = LoadSession(*record);
    if (!loaded.ok()) return loaded.status();
    (*loaded)->engine->AppendTrajectory(&out);
    return out;
  }
  absl::StatusOr<std::vector<storage::TrajectoryPoseRecord>> poses =
      store_->LoadTrajectory(session_id);
  if (!poses.ok()) return poses.status();
  for (const storage::TrajectoryPoseRecord& pose : *poses) {
    *out.add_poses() = TrajectoryPoseFromRecord(pose);
  }
  return out;
}

absl::StatusOr<v1::OccupancyGrid> SlamRegistry::GetOccupancyGrid(
    const std::string& session_id, std::optional<double> resolution) {
  const double cell = resolution.value_or(0.05);
  if (absl::Status s = InRange(cell, "resolution", 0.01, 1.0, false, "m"); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<Session>> session = SessionToRead(
      session_id, absl::FailedPreconditionError(absl::StrCat(
                      "SLAM session ", Quoted(session_id),
                      " is a visual session: only laser sessions have an occupancy grid")));
  if (!session.ok()) return session.status();
  v1::OccupancyGrid grid;
  grid.set_session_id(session_id);
  std::lock_guard<std::mutex> lock((*session)->engine_mu);
  grid.set_map_revision((*session)->map_revision);
  if (absl::Status s = (*session)->engine->FillOccupancyGrid(cell, &grid); !s.ok()) {
    return absl::Status(s.code(),
                        absl::StrCat("SLAM session ", Quoted(session_id), ": ", s.message()));
  }
  return grid;
}

absl::Status SlamRegistry::CheckpointAll() {
  std::vector<std::shared_ptr<Session>> sessions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, session] : sessions_) sessions.push_back(session);
  }
  absl::Status first;
  for (const std::shared_ptr<Session>& session : sessions) {
    absl::Status s = Checkpoint(*session, /*close=*/false);
    if (!s.ok()) {
      spdlog::error("SLAM session {}: checkpoint failed: {}", session->id, s.ToString());
      if (first.ok()) first = s;
    }
  }
  return first;
}

absl::Status SlamRegistry::Shutdown() {
  std::lock_guard<std::mutex> shutdown_lock(shutdown_mutex_);
  if (shut_down_) return absl::OkStatus();
  shut_down_ = true;
  shutting_down_ = true;  // Submit and OpenStream refuse from now on
  std::vector<std::shared_ptr<Session>> sessions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, session] : sessions_) sessions.push_back(session);
  }
  // The workers still run: let every accepted message be processed (and answered) first.
  for (const std::shared_ptr<Session>& session : sessions) WaitIdle(*session);
  {
    std::lock_guard<std::mutex> lock(timer_mutex_);
    stop_timer_ = true;
  }
  timer_cv_.notify_all();
  if (timer_.joinable()) timer_.join();
  if (lease_thread_.joinable()) lease_thread_.join();
  absl::Status status = CheckpointAll();
  // Saved: another server may take the sessions over at once instead of waiting for expiry.
  for (const std::shared_ptr<Session>& session : sessions) leases_.Release(session->id);
  {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    stop_workers_ = true;
  }
  pool_cv_.notify_all();
  for (std::thread& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
  if (journal_ != nullptr) {
    journal_->Stop();
    const SlamJournalStats stats = journal_->stats();
    spdlog::info("SLAM journal: {} messages ({:.1f} MB) in {} transactions, {:.2f} ms each on "
                 "average, {} failed",
                 stats.messages, stats.bytes / 1e6, stats.batches,
                 stats.batches > 0 ? stats.write_ms / static_cast<double>(stats.batches) : 0.0,
                 stats.failed_batches);
  }
  spdlog::info("SLAM: stopped; {} sessions in memory were saved", sessions.size());
  return status;
}

}  // namespace waymark::service
