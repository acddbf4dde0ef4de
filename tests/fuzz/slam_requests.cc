// Fuzz target slam_requests: the request of every unary SlamService RPC (CreateSession, GetMap,
// GetTrajectory, CloseSession, ListSessions, DeleteSession, GetOccupancyGrid, ImportMap), served
// by the real SlamServiceImpl over a SlamRegistry on an in-memory SQLite store, and a
// StreamSensorData message admitted to a session and processed by its engine, as the stream's
// handler hands it to the registry. Detector models, localization on a stored map, imported
// grids, the occupancy grid's resolution, odometry, scans and camera frames all come from the
// request. (CreateSession's configurations and SensorData's conversions are also targets of their
// own, session_config and sensor_data, which are faster per input.)
//
// The registry is made once per process with four sessions of robot "robot-1": @0 an imported map
// (closed), @1 an open laser session, @2 an open visual session and @3 a closed laser session
// that processed a few scans of a room (a segment map, a trajectory, kept scans). A session id (or
// a localization's map id) "@0".."@3" in a request names them; "@new" a fresh open laser session
// made for that input. The fuzzer cannot guess a random session id, so without these names every
// request would end at NOT_FOUND. After each input the state is put back: sessions an input
// created are deleted, and a fixture an input closed, deleted or fed an accepted message is made
// again.
//
// Oracle beyond "no crash": the configuration a created laser session reports (what is stored and
// rebuilt after a restart) must be accepted again and stay the same.

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "server/service/auth/authenticator.h"
#include "server/service/runtime/grpc_status.h"
#include "server/service/slam/slam_params.h"
#include "server/service/slam/slam_registry.h"
#include "server/service/slam_service.h"
#include "storage/slam_store.h"
#include "tests/fuzz/fuzz_images.h"
#include "tests/fuzz/fuzz_targets.h"
#include "tests/fuzz/service_calls.h"

namespace waymark::fuzz {
namespace {

using service::SlamServiceImpl;

constexpr char kRobot[] = "robot-1";
constexpr int kBeams = 181;
constexpr double kPi = 3.14159265358979323846;

v1::CreateSessionRequest LaserRequest() {
  v1::CreateSessionRequest request;
  request.set_robot_id(kRobot);
  v1::LaserGeometry* laser = request.mutable_laser()->mutable_laser();
  laser->set_angle_min(-kPi / 2);
  laser->set_angle_increment(kPi / (kBeams - 1));
  laser->set_beam_count(kBeams);
  return request;
}

v1::CreateSessionRequest VisualRequest() {
  v1::CreateSessionRequest request;
  request.set_robot_id(kRobot);
  v1::CameraIntrinsics* camera = request.mutable_visual()->mutable_camera();
  camera->set_fx(60);
  camera->set_fy(60);
  camera->set_cx(kViewWidth / 2.0);
  camera->set_cy(kViewHeight / 2.0);
  camera->set_width(kViewWidth);  // FuzzView's frames
  camera->set_height(kViewHeight);
  return request;
}

// A 4 x 3 m room seen by an occupancy grid: walls occupied, the inside free, 0.1 m cells.
v1::ImportMapRequest MapRequest() {
  v1::ImportMapRequest request;
  request.set_robot_id(kRobot);
  request.set_name("room");
  v1::OccupancyGrid* grid = request.mutable_grid();
  constexpr int kWidth = 40, kHeight = 30;
  grid->set_resolution(0.1);
  grid->mutable_origin()->set_x(-2);
  grid->mutable_origin()->set_y(-1.5);
  grid->set_width(kWidth);
  grid->set_height(kHeight);
  std::string cells(kWidth * kHeight, '\0');
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const bool wall = x == 0 || y == 0 || x == kWidth - 1 || y == kHeight - 1;
      cells[y * kWidth + x] = static_cast<char>(wall ? 100 : 0);
    }
  }
  grid->set_cells(cells);
  return request;
}

// The scan of a 6 x 4 m room (walls at x = +-3, y = +-2) from (x, 0) facing +x.
v1::SensorData RoomScan(uint64_t sequence, double stamp, double x) {
  v1::SensorData data;
  data.set_sequence(sequence);
  v1::LaserScan* scan = data.mutable_scan();
  scan->set_stamp(stamp);
  for (int i = 0; i < kBeams; ++i) {
    const double a = -kPi / 2 + i * kPi / (kBeams - 1);
    const double c = std::cos(a), s = std::sin(a);
    double range = c > 1e-9 ? (3 - x) / c : 1e9;
    if (std::abs(s) > 1e-9) range = std::min(range, 2 / std::abs(s));
    scan->add_ranges(static_cast<float>(range));
  }
  return data;
}

v1::SensorData Odometry(uint64_t sequence, double stamp, double x) {
  v1::SensorData data;
  data.set_sequence(sequence);
  data.mutable_odometry()->set_stamp(stamp);
  data.mutable_odometry()->mutable_pose()->set_x(x);
  return data;
}

// A created laser session's configuration is stored and rebuilt after a restart: it must pass
// the checks again, unchanged.
void CheckStoredConfig(const v1::CreateSessionRequest&, const v1::Session& created) {
  if (!created.has_laser()) return;
  absl::StatusOr<v1::LaserSlamConfig> again = service::EffectiveLaserConfig(created.laser());
  Require(again.status(), "a created laser session's configuration, read back");
  Require(again->SerializeAsString() == created.laser().SerializeAsString(),
          "a created laser session's configuration changes when read back");
}

class SlamFixture {
 public:
  SlamFixture() {
    QuietLogs();
    auto store = storage::OpenSqliteSlamStore(":memory:");
    Require(store.status(), "opening an in-memory SLAM store");
    service::SlamRegistryOptions options;
    options.workers = 1;
    options.checkpoint_seconds = 0;  // no timer-driven work between inputs
    auto registry = service::SlamRegistry::Create(*std::move(store), options);
    Require(registry.status(), "creating the SLAM registry");
    registry_ = *std::move(registry);
    // Unary calls only: no stream limiter or idle reaper is used.
    service_ = std::make_unique<SlamServiceImpl>(registry_.get(), auth_.get(), nullptr, nullptr);
    SlamServiceImpl* s = service_.get();
    const auto resolve = [this](auto* request) { Resolve(request->mutable_session_id()); };
    rpcs_ = {
        UnaryRpc(s, &SlamServiceImpl::CreateSession, CheckStoredConfig,
                 [this](v1::CreateSessionRequest* request) {
                   if (request->has_laser() && request->laser().has_localize()) {
                     Resolve(
                         request->mutable_laser()->mutable_localize()->mutable_map_session_id());
                   }
                 }),
        UnaryRpc(s, &SlamServiceImpl::GetMap, NoCheck(), resolve),
        UnaryRpc(s, &SlamServiceImpl::GetTrajectory, NoCheck(), resolve),
        UnaryRpc(s, &SlamServiceImpl::CloseSession, NoCheck(), resolve),
        UnaryRpc(s, &SlamServiceImpl::ListSessions),
        UnaryRpc(s, &SlamServiceImpl::DeleteSession, NoCheck(), resolve),
        UnaryRpc(s, &SlamServiceImpl::GetOccupancyGrid, NoCheck(), resolve),
        UnaryRpc(s, &SlamServiceImpl::ImportMap),
        [this](const RequestInput& input) { StreamOne(input); },
    };
    for (int k = 0; k < kFixtures; ++k) Build(k);
  }

  void Run(const RequestInput& input) {
    rpcs_[input.rpc % rpcs_.size()](input);
    Restore();
  }

 private:
  static constexpr int kFixtures = 4;

  // "@0".."@3": the fixtures; "@new": a session made for this input (deleted after it).
  void Resolve(std::string* id) {
    if (*id == "@new") {
      absl::StatusOr<v1::Session> fresh = registry_->CreateSession(LaserRequest());
      Require(fresh.status(), "creating a session for an input");
      *id = fresh->session_id();
      return;
    }
    if (id->size() == 2 && (*id)[0] == '@' && (*id)[1] >= '0' && (*id)[1] < '0' + kFixtures) {
      *id = ids_[(*id)[1] - '0'];
    }
  }

  std::string Created(const absl::StatusOr<v1::Session>& session) {
    Require(session.status(), "creating a fixture session");
    return session->session_id();
  }

  void Build(int k) {
    switch (k) {
      case 0:
        ids_[0] = Created(registry_->ImportMap(MapRequest()));
        break;
      case 1:
        ids_[1] = Created(registry_->CreateSession(LaserRequest()));
        break;
      case 2:
        ids_[2] = Created(registry_->CreateSession(VisualRequest()));
        break;
      default: {
        ids_[3] = Created(registry_->CreateSession(LaserRequest()));
        auto stream = registry_->OpenStream(ids_[3], [](const v1::SlamUpdate&) {});
        Require(stream.status(), "streaming to a fixture session");
        for (int i = 0; i < 6; ++i) {
          const double stamp = 1 + i, x = -1 + 0.3 * i;
          Require((*stream)->Submit(Odometry(2 * i, stamp, x)), "a fixture's odometry");
          Require((*stream)->Submit(RoomScan(2 * i + 1, stamp + 0.01, x)), "a fixture's scan");
        }
        (*stream)->Close();  // waits until every scan is processed
        Require(registry_->CloseSession(ids_[3]).status(), "closing a fixture session");
      }
    }
  }

  // StreamSensorData: the message as a stream's first, as the service's handler hands it to the
  // registry (OpenStream on its session, Submit: admission, then the engine on a worker thread);
  // closing the stream waits until it is processed and answered.
  void StreamOne(const RequestInput& input) {
    std::optional<v1::SensorData> data = ParseRequest<v1::SensorData>(input);
    // The handler refuses a first message without a session before the registry sees it.
    if (!data.has_value() || data->session_id().empty()) return;
    Resolve(data->mutable_session_id());
    auto stream = registry_->OpenStream(
        data->session_id(), [](const v1::SlamUpdate& update) { RecordAnswer(&update, {}); });
    if (!stream.ok()) {
      RecordAnswer(nullptr, service::ToGrpcStatus(stream.status()));
      return;
    }
    const absl::Status submitted = (*stream)->Submit(*data);
    // The service answers a refused message with a rejection quoting this status.
    if (!submitted.ok()) RecordAnswer(nullptr, service::ToGrpcStatus(submitted));
    const bool accepted = submitted.ok();
    (*stream)->Close();
    if (accepted) fed_ = data->session_id();
  }

  void Restore() {
    absl::StatusOr<v1::ListSessionsResponse> all = registry_->ListSessions("");
    Require(all.status(), "listing sessions");
    for (const v1::Session& session : all->sessions()) {
      if (std::find(std::begin(ids_), std::end(ids_), session.session_id()) != std::end(ids_)) {
        continue;
      }
      Require(registry_->DeleteSession(session.session_id(), /*force=*/true).status(),
              "deleting a session an input created");
    }
    for (int k = 0; k < kFixtures; ++k) {
      const v1::Session::State expected =
          k == 1 || k == 2 ? v1::Session::OPEN : v1::Session::CLOSED;
      absl::StatusOr<v1::Session> now = registry_->GetSession(ids_[k]);
      if (now.ok() && now->state() == expected && ids_[k] != fed_) continue;
      if (now.ok()) {
        Require(registry_->DeleteSession(ids_[k], /*force=*/true).status(),
                "deleting a changed fixture session");
      }
      Build(k);
    }
    fed_.clear();
  }

  std::unique_ptr<service::Authenticator> auth_ = service::Authenticator::AuthOff();
  std::unique_ptr<service::SlamRegistry> registry_;
  std::unique_ptr<SlamServiceImpl> service_;
  std::vector<RpcHandler> rpcs_;
  std::string ids_[kFixtures];
  std::string fed_;  // the session an input's message was accepted by: its stamps moved on
};

void SlamRequests(const uint8_t* data, size_t size) {
  // Never destroyed: its registry's threads must not be stopped by static destructors.
  static SlamFixture* fixture = new SlamFixture;
  if (std::optional<RequestInput> input = SplitRequestInput(data, size)) fixture->Run(*input);
}

// A darknet model small enough for a seed: one 1x1 convolution with 2 filters over 3 channels,
// and weights of exactly the size OpenCV's blobs need (version 0.2 header: 3 int32 + int64, then
// 2 biases and 6 weights).
void TinyDarknet(v1::DetectorConfig* detector) {
  detector->set_kind(v1::DetectorConfig::YOLO);
  detector->set_model_cfg(
      "[net]\nwidth=32\nheight=32\nchannels=3\n[convolutional]\nfilters=2\nsize=1\nstride=1\n"
      "pad=0\nactivation=linear\n");
  std::string weights(12 + 8 + 8 * 4, '\0');
  weights[4] = 2;  // minor version 2
  detector->set_model_weights(weights);
  detector->add_class_names("person");
  detector->add_class_names("car");
}

std::vector<std::string> SlamSeeds() {
  std::vector<std::string> seeds;
  v1::CreateSessionRequest laser = LaserRequest();
  v1::LaserSlamParams* params = laser.mutable_laser()->mutable_params();
  params->set_max_range(8);
  params->set_loop_closure(false);
  v1::ExplorationConfig* exploration = laser.mutable_laser()->mutable_exploration();
  exploration->set_mode(v1::ExplorationConfig::ACTIVE);
  exploration->set_linear_steps(5);
  exploration->set_angular_steps(7);
  exploration->set_grid_resolution(0.2);
  seeds.push_back(RequestSeed(0, laser));
  v1::CreateSessionRequest localize = LaserRequest();
  localize.mutable_laser()->mutable_localize()->set_map_session_id("@0");
  localize.mutable_laser()->mutable_localize()->mutable_initial_pose()->set_x(0.5);
  localize.mutable_laser()->mutable_localize()->set_initial_sigma_xy(0.3);
  seeds.push_back(RequestSeed(0, localize));
  v1::CreateSessionRequest visual = VisualRequest();
  visual.mutable_visual()->mutable_camera()->add_distortion(0.1);
  visual.mutable_visual()->set_filter(v1::VisualSlamConfig::FILTER_PROVEN);
  visual.mutable_visual()->mutable_params()->set_orb_features(200);
  visual.mutable_visual()->mutable_detector()->set_kind(v1::DetectorConfig::HOG);
  seeds.push_back(RequestSeed(0, visual));
  v1::CreateSessionRequest yolo = VisualRequest();
  TinyDarknet(yolo.mutable_visual()->mutable_detector());
  seeds.push_back(RequestSeed(0, yolo));

  for (const char* id : {"@3", "@2"}) {
    v1::GetMapRequest map;
    map.set_session_id(id);
    seeds.push_back(RequestSeed(1, map));
    v1::GetTrajectoryRequest trajectory;
    trajectory.set_session_id(id);
    seeds.push_back(RequestSeed(2, trajectory));
  }
  v1::CloseSessionRequest close;
  close.set_session_id("@new");
  seeds.push_back(RequestSeed(3, close));
  v1::ListSessionsRequest list;
  list.set_robot_id(kRobot);
  seeds.push_back(RequestSeed(4, list));
  for (const char* id : {"@new", "@0"}) {
    v1::DeleteSessionRequest remove;
    remove.set_session_id(id);
    remove.set_force(true);
    seeds.push_back(RequestSeed(5, remove));
  }
  for (const char* id : {"@3", "@0"}) {
    v1::GetOccupancyGridRequest grid;
    grid.set_session_id(id);
    grid.set_resolution(0.1);
    seeds.push_back(RequestSeed(6, grid));
  }
  seeds.push_back(RequestSeed(7, MapRequest()));

  v1::SensorData odometry = Odometry(1, 1.0, 0.2);
  odometry.set_session_id("@1");
  seeds.push_back(RequestSeed(8, odometry));
  v1::SensorData scan = RoomScan(2, 1.0, 0.2);
  scan.set_session_id("@1");
  seeds.push_back(RequestSeed(8, scan));
  v1::SensorData frame;
  frame.set_session_id("@2");
  frame.set_sequence(3);
  frame.mutable_frame()->set_stamp(1.0);
  frame.mutable_frame()->set_image(adapters::EncodeJpeg(FuzzView(5, 0)));
  v1::BoundingBox* box = frame.mutable_frame()->add_boxes();
  box->set_x(10);
  box->set_y(5);
  box->set_width(20);
  box->set_height(30);
  box->set_label("person");
  box->set_confidence(0.9f);
  seeds.push_back(RequestSeed(8, frame));
  v1::SensorData rgbd;
  rgbd.set_session_id("@2");
  rgbd.set_sequence(4);
  rgbd.mutable_frame()->set_stamp(2.0);
  rgbd.mutable_frame()->set_image(adapters::EncodePng(FuzzView(5, 30)));
  rgbd.mutable_frame()->set_depth(adapters::EncodePng(FuzzDepth()));
  rgbd.mutable_frame()->set_want_features(true);
  seeds.push_back(RequestSeed(8, rgbd));
  return seeds;
}

}  // namespace

FuzzTarget SlamRequestsTarget() { return {"slam_requests", SlamRequests, SlamSeeds}; }

}  // namespace waymark::fuzz
