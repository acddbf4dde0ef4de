#include "client/load/load_generator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

#include "absl/strings/str_cat.h"
#include "client/sim/sim_robot.h"
#include "client/sim/sim_world.h"
#include "client/common/steady_clock.h"
#include "client/robot/laser_session.h"

namespace waymark::cli {
namespace {

using adapters::SteadySeconds;

// Sleeps until `when` (steady seconds). False, at once or on waking, when the run is over: `when`
// is at or past `end`, or a stop was requested. Sleeps in short slices so a stop is prompt.
bool SleepUntil(double when, double end, const std::atomic<bool>& stop) {
  constexpr double kSlice = 0.05;
  while (true) {
    if (stop || when >= end) return false;
    const double now = SteadySeconds();
    if (now >= when) return true;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(when - now, kSlice)));
  }
}

// The tick after `tick`: one period on, or now if the caller fell behind (no catch-up burst).
double NextTick(double tick, double period) { return std::max(tick + period, SteadySeconds()); }

double MsSince(double start) { return (SteadySeconds() - start) * 1000.0; }

// Straight on at full speed until a wall is near ahead (or the body touches one), then turn on
// the spot until the way ahead is clear: enough to keep a simulated robot moving around a world
// for as long as a run lasts, so the SLAM sessions see new walls and real motion.
class Wanderer {
 public:
  // The velocities for the next scan period, from the latest scan.
  std::pair<double, double> Update(const adapters::LaserReading& reading,
                                   const adapters::LaserLayout& layout, bool bumped,
                                   double max_linear, double max_angular) {
    constexpr double kFrontHalfAngle = 0.5;  // rad either side of straight ahead
    constexpr double kStopDistance = 0.7;    // m
    constexpr double kClearDistance = 1.2;   // m: hysteresis, so it does not dither
    double front = layout.no_return_range;
    for (size_t i = 0; i < reading.ranges.size(); ++i) {
      const double bearing = layout.angle_min + i * layout.angle_increment;
      if (std::fabs(bearing) <= kFrontHalfAngle) front = std::min<double>(front, reading.ranges[i]);
    }
    if (turning_) {
      turning_ = front < kClearDistance;
    } else {
      turning_ = bumped || front < kStopDistance;
    }
    return turning_ ? std::make_pair(0.0, max_angular) : std::make_pair(max_linear, 0.0);
  }

 private:
  bool turning_ = false;
};

// Shared by every robot of a run.
struct Fleet {
  Fleet(const LoadOptions& options, const std::vector<std::string>& queries,
        const adapters::World& world, LoadRecorder& recorder, const std::atomic<bool>& stop)
      : options(options), queries(queries), world(world), recorder(recorder), stop(stop) {}

  const LoadOptions& options;
  const std::vector<std::string>& queries;
  const adapters::World& world;
  LoadRecorder& recorder;
  const std::atomic<bool>& stop;
  double start = 0;  // steady seconds
  double end = 0;

  std::mutex mutex;  // guards result
  LoadResult result;
};

class Robot {
 public:
  Robot(Fleet& fleet, int index, RobotClients clients)
      : fleet_(fleet), index_(index), clients_(std::move(clients)) {}

  void Start() {
    if (fleet_.options.recognize_hz > 0) recognizer_ = std::thread([this] { Recognize(); });
    if (fleet_.options.scan_hz > 0) slam_ = std::thread([this] { Slam(); });
  }
  void Join() {
    if (recognizer_.joinable()) recognizer_.join();
    if (slam_.joinable()) slam_.join();
  }

 private:
  // This robot's first tick of a `period`, staggered over one period across the fleet.
  double FirstTick(double period) const {
    return fleet_.start + period * index_ / fleet_.options.robots;
  }

  void Recognize() {
    const double period = 1.0 / fleet_.options.recognize_hz;
    LoadRecorder& recorder = fleet_.recorder;
    int64_t answered = 0, recognized = 0;
    size_t next_query = static_cast<size_t>(index_);
    for (double tick = FirstTick(period); SleepUntil(tick, fleet_.end, fleet_.stop);
         tick = NextTick(tick, period)) {
      v1::RecognizeRequest request;
      request.set_database(fleet_.options.database);
      request.mutable_image()->set_data(fleet_.queries[next_query++ % fleet_.queries.size()]);
      request.mutable_image()->set_stamp(SteadySeconds());
      recorder.Sent(kRecognizeRpc);
      const double sent = SteadySeconds();
      absl::StatusOr<v1::RecognizeResponse> response =
          clients_.crossing->RecognizeCrossing(request);
      if (!response.ok()) {
        recorder.Failed(kRecognizeRpc, response.status().code());
        continue;
      }
      recorder.Answered(kRecognizeRpc, MsSince(sent));
      ++answered;
      if (response->recognized()) ++recognized;
    }
    std::lock_guard<std::mutex> lock(fleet_.mutex);
    fleet_.result.recognitions += answered;
    fleet_.result.recognized += recognized;
  }

  // A unary SLAM call, recorded under `rpc`.
  template <typename Call>
  auto Timed(const char* rpc, Call call) -> decltype(call()) {
    fleet_.recorder.Sent(rpc);
    const double sent = SteadySeconds();
    auto result = call();
    if (result.ok()) {
      fleet_.recorder.Answered(rpc, MsSince(sent));
    } else {
      fleet_.recorder.Failed(rpc, result.status().code());
    }
    return result;
  }

  void Slam() {
    const LoadOptions& options = fleet_.options;
    LoadRecorder& recorder = fleet_.recorder;
    adapters::SimOptions sim_options;
    sim_options.seed = static_cast<uint64_t>(index_) + 1;
    adapters::Simulation sim(fleet_.world, sim_options);
    const adapters::LaserLayout layout = sim.laser_layout();
    const std::string robot_id = absl::StrCat(options.robot_prefix, "-", index_);
    v1::CreateSessionRequest request = LaserSessionRequest(
        layout, robot_id, absl::StrCat("bench load ", robot_id), v1::ExplorationConfig::PASSIVE);
    if (!options.prune) request.mutable_laser()->mutable_params()->set_prune_redundant_submaps(false);
    absl::StatusOr<v1::Session> session =
        Timed(kCreateSessionRpc, [&] { return clients_.slam->CreateSession(request); });
    if (!session.ok()) return;

    // Scans waiting for their SlamUpdate, by stamp (an update carries its scan's stamp).
    std::mutex pending_mutex;
    std::map<double, double> pending;  // stamp -> steady seconds sent
    int64_t skipped = 0;               // guarded by pending_mutex
    auto on_update = [&](const v1::SlamUpdate& update) {
      if (update.has_rejection()) {
        recorder.Failed(kSensorStreamRpc, static_cast<absl::StatusCode>(update.rejection().code()));
        return;
      }
      if (update.skipped()) {
        std::lock_guard<std::mutex> lock(pending_mutex);
        ++skipped;
      }
      double sent;
      {
        std::lock_guard<std::mutex> lock(pending_mutex);
        auto it = pending.find(update.stamp());
        if (it == pending.end()) return;
        sent = it->second;
        pending.erase(it);
      }
      recorder.Answered(kSensorStreamRpc, MsSince(sent));
    };
    std::unique_ptr<client::SensorStream> stream = clients_.slam->StreamSensorData(
        session->session_id(), client::kDefaultScanWindow, on_update);

    const double odometry_period = 1.0 / options.odometry_hz;
    const double scan_period = 1.0 / options.scan_hz;
    const double origin = FirstTick(odometry_period);  // simulated time 0
    double next_odometry = origin, next_scan = origin;
    double last_odometry_stamp = -1, last_scan_stamp = -1;
    Wanderer wanderer;
    absl::Status sent = absl::OkStatus();
    while (sent.ok() && SleepUntil(std::min(next_odometry, next_scan), fleet_.end, fleet_.stop)) {
      const double now = SteadySeconds();
      sim.Advance(std::max(0.0, (now - origin) - sim.now()));  // simulated time = wall time
      // Stamps must increase per sensor; equal stamps across sensors are fine.
      if (next_odometry <= now && sim.now() > last_odometry_stamp) {
        v1::Odometry odometry;
        odometry.set_stamp(sim.now());
        *odometry.mutable_pose() = ToProto(sim.odometry_pose());
        recorder.Sent(kSensorStreamRpc);
        sent = stream->SendOdometry(odometry);
        last_odometry_stamp = sim.now();
        next_odometry = NextTick(next_odometry, odometry_period);
      }
      if (sent.ok() && next_scan <= now && sim.now() > last_scan_stamp) {
        const adapters::LaserReading reading = sim.Scan();
        const auto [linear, angular] = wanderer.Update(
            reading, layout, sim.bumped(), sim.options().max_linear, sim.options().max_angular);
        sim.base().SetVelocity(linear, angular).IgnoreError();  // the simulator never fails
        v1::LaserScan scan;
        scan.set_stamp(sim.now());
        scan.mutable_ranges()->Assign(reading.ranges.begin(), reading.ranges.end());
        {
          std::lock_guard<std::mutex> lock(pending_mutex);
          pending[scan.stamp()] = SteadySeconds();
        }
        recorder.Sent(kSensorStreamRpc);
        sent = stream->SendScan(scan);  // may wait for the flow-control window
        last_scan_stamp = sim.now();
        next_scan = NextTick(next_scan, scan_period);
      }
    }
    // Every scan answered, or the reason the stream broke.
    const absl::Status finished = stream->Finish();
    if (!finished.ok()) recorder.Failed(kSensorStreamRpc, finished.code());
    const client::SensorStream::Stats stats = stream->stats();
    stream.reset();
    const bool closed = Timed(kCloseSessionRpc, [&] {
                          return clients_.slam->CloseSession(session->session_id());
                        }).ok();

    std::lock_guard<std::mutex> lock(fleet_.mutex);
    ++fleet_.result.sessions_created;
    fleet_.result.sessions_closed += closed ? 1 : 0;
    fleet_.result.scans_sent += static_cast<int64_t>(stats.scans_sent);
    fleet_.result.scans_answered += static_cast<int64_t>(stats.updates);
    fleet_.result.scans_skipped += skipped;  // the reader thread has ended: no lock needed
    fleet_.result.odometry_sent += static_cast<int64_t>(stats.odometry_sent);
  }

  Fleet& fleet_;
  const int index_;
  RobotClients clients_;
  std::thread recognizer_;
  std::thread slam_;
};

absl::Status ValidateRate(const char* name, double hz, double max_hz) {
  if (!std::isfinite(hz) || hz < 0 || hz > max_hz) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, " = ", hz, " Hz is outside [0, ", max_hz, "]"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<LoadResult> RunLoad(const LoadOptions& options,
                                   const std::vector<std::string>& queries,
                                   const ConnectRobot& connect, LoadRecorder& recorder,
                                   const std::atomic<bool>& stop) {
  if (options.robots < 1) {
    return absl::InvalidArgumentError(absl::StrCat("robots = ", options.robots, " (at least 1)"));
  }
  if (!(options.duration_s > 0)) {
    return absl::InvalidArgumentError(absl::StrCat("duration = ", options.duration_s, " s"));
  }
  for (const absl::Status& s : {ValidateRate("recognize rate", options.recognize_hz, 100),
                                ValidateRate("scan rate", options.scan_hz, 100),
                                ValidateRate("odometry rate", options.odometry_hz, 100)}) {
    if (!s.ok()) return s;
  }
  if (options.recognize_hz == 0 && options.scan_hz == 0) {
    return absl::InvalidArgumentError("the recognize and scan rates are both 0: nothing to do");
  }
  if (options.scan_hz > 0 && options.odometry_hz == 0) {
    return absl::InvalidArgumentError("a SLAM session needs odometry: odometry rate is 0");
  }
  if (options.recognize_hz > 0 && queries.empty()) {
    return absl::InvalidArgumentError("no query images to recognize");
  }
  absl::StatusOr<adapters::World> world = adapters::LoadWorld(options.world);
  if (!world.ok()) return world.status();

  Fleet fleet(options, queries, *world, recorder, stop);
  std::vector<std::unique_ptr<Robot>> robots;
  for (int i = 0; i < options.robots; ++i) {
    robots.push_back(std::make_unique<Robot>(fleet, i, connect()));
  }
  fleet.start = SteadySeconds();
  fleet.end = fleet.start + options.duration_s;
  for (auto& robot : robots) robot->Start();
  for (auto& robot : robots) robot->Join();
  fleet.result.elapsed_s = std::min(SteadySeconds(), fleet.end) - fleet.start;
  return fleet.result;
}

}  // namespace waymark::cli
