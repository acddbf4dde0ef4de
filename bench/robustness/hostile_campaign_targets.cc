#include "bench/robustness/hostile_campaign_targets.h"

#include <cmath>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "client/lib/crossing_client.h"
#include "client/lib/slam_client.h"
#include "client/lib/token_client.h"
#include "grpc/health/v1/health.pb.h"
#include "tests/service/slam_test_world.h"
#include "tests/support/synthetic_scene.h"
#include "waymark/v1/token.pb.h"

namespace waymark::bench::hostile {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::MethodDescriptor;

// A new call's valid messages, for one campaign thread.
using CallSource = std::function<MessageSource(int thread, Rng& rng)>;

bool Chance(Rng& rng, double p) { return std::bernoulli_distribution(p)(rng); }

template <class M>
std::unique_ptr<Message> Copy(const M& message) {
  return std::make_unique<M>(message);
}

// The same request for every message of every call (unary RPCs).
CallSource Always(std::shared_ptr<const Message> message) {
  return [message](int, Rng&) -> MessageSource {
    return [message] {
      std::unique_ptr<Message> copy(message->New());
      copy->CopyFrom(*message);
      return copy;
    };
  };
}

template <class M>
CallSource Always(const M& message) {
  return Always(std::shared_ptr<const Message>(std::make_shared<M>(message)));
}

// A request of an RPC without a hand-made one: every field set to something plausible (a short
// string, 1, the first named enum value), submessages a few levels deep.
void FillPlausible(Message& m, int depth) {
  const google::protobuf::Reflection* r = m.GetReflection();
  for (int i = 0; i < m.GetDescriptor()->field_count(); ++i) {
    const FieldDescriptor* f = m.GetDescriptor()->field(i);
    if (f->containing_oneof() != nullptr && r->HasOneof(m, f->containing_oneof())) continue;
    const bool rep = f->is_repeated();
    switch (f->cpp_type()) {
      case FieldDescriptor::CPPTYPE_MESSAGE:
        if (depth < 3) FillPlausible(rep ? *r->AddMessage(&m, f) : *r->MutableMessage(&m, f), depth + 1);
        break;
      case FieldDescriptor::CPPTYPE_STRING: rep ? r->AddString(&m, f, "x") : r->SetString(&m, f, "x"); break;
      case FieldDescriptor::CPPTYPE_DOUBLE: rep ? r->AddDouble(&m, f, 1) : r->SetDouble(&m, f, 1); break;
      case FieldDescriptor::CPPTYPE_FLOAT: rep ? r->AddFloat(&m, f, 1) : r->SetFloat(&m, f, 1); break;
      case FieldDescriptor::CPPTYPE_INT32: rep ? r->AddInt32(&m, f, 1) : r->SetInt32(&m, f, 1); break;
      case FieldDescriptor::CPPTYPE_INT64: rep ? r->AddInt64(&m, f, 1) : r->SetInt64(&m, f, 1); break;
      case FieldDescriptor::CPPTYPE_UINT32: rep ? r->AddUInt32(&m, f, 1) : r->SetUInt32(&m, f, 1); break;
      case FieldDescriptor::CPPTYPE_UINT64: rep ? r->AddUInt64(&m, f, 1) : r->SetUInt64(&m, f, 1); break;
      case FieldDescriptor::CPPTYPE_BOOL: rep ? r->AddBool(&m, f, true) : r->SetBool(&m, f, true); break;
      case FieldDescriptor::CPPTYPE_ENUM: {
        const int value = f->enum_type()->value(f->enum_type()->value_count() > 1 ? 1 : 0)->number();
        rep ? r->AddEnumValue(&m, f, value) : r->SetEnumValue(&m, f, value);
        break;
      }
    }
  }
}

CallSource Generic(const MethodDescriptor* method) {
  const Message* prototype =
      google::protobuf::MessageFactory::generated_factory()->GetPrototype(method->input_type());
  std::shared_ptr<Message> message(prototype->New());
  FillPlausible(*message, 0);
  return Always(std::shared_ptr<const Message>(message));
}

// --- requests --------------------------------------------------------------------------------

v1::CreateSessionRequest VisualSession(const std::string& robot) {
  v1::CreateSessionRequest r;
  r.set_robot_id(robot);
  r.set_name("hostile campaign camera of " + robot);
  v1::VisualSlamConfig* visual = r.mutable_visual();
  v1::CameraIntrinsics* camera = visual->mutable_camera();
  camera->set_fx(140);
  camera->set_fy(140);
  camera->set_cx(80);
  camera->set_cy(60);
  camera->set_width(160);
  camera->set_height(120);
  for (double k : {0.01, -0.002, 0.0, 0.0, 0.0}) camera->add_distortion(k);
  visual->set_depth_scale(5000);
  visual->set_filter(v1::VisualSlamConfig::FILTER_FULL);
  visual->mutable_params()->set_orb_features(300);
  visual->mutable_params()->set_keyframe_distance(0.1);
  return r;
}

v1::CreateSessionRequest ActiveLaserSession(const std::string& robot) {
  v1::CreateSessionRequest r = Fixtures::LaserSession(robot);
  v1::ExplorationConfig* exploration = r.mutable_laser()->mutable_exploration();
  exploration->set_mode(v1::ExplorationConfig::ACTIVE);
  exploration->set_max_linear(0.15);
  exploration->set_max_angular(0.17);
  exploration->set_robot_radius(0.25);
  exploration->set_grid_resolution(0.1);
  r.mutable_laser()->mutable_laser_pose()->set_x(0.1);
  return r;
}

v1::CreateSessionRequest LocalizationSession(const std::string& robot, const std::string& map) {
  v1::CreateSessionRequest r = Fixtures::LaserSession(robot);
  v1::LocalizationConfig* localize = r.mutable_laser()->mutable_localize();
  localize->set_map_session_id(map);
  localize->mutable_initial_pose()->set_x(0.2);
  localize->set_initial_sigma_xy(0.5);
  localize->set_initial_sigma_theta(0.2);
  return r;
}

// A 3.2 m x 2.4 m room at 5 cm: walls around, free inside, a band of unknown cells.
v1::OccupancyGrid RoomGrid() {
  v1::OccupancyGrid grid;
  const int width = 64, height = 48;
  grid.set_resolution(0.05);
  grid.mutable_origin()->set_x(-1.6);
  grid.mutable_origin()->set_y(-1.2);
  grid.set_width(width);
  grid.set_height(height);
  std::string cells(width * height, 0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool wall = x == 0 || y == 0 || x == width - 1 || y == height - 1;
      cells[y * width + x] = static_cast<char>(wall ? 100 : y > 40 ? -1 : 0);
    }
  }
  grid.set_cells(cells);
  return grid;
}

v1::ImportMapRequest ImportRequest(const std::string& robot, const std::string& name) {
  v1::ImportMapRequest r;
  r.set_robot_id(robot);
  r.set_name(name);
  *r.mutable_grid() = RoomGrid();
  return r;
}

// Enrollment requests into enroll-db: eight headings of one crossing, half the calls with
// skip_invalid (so a stream goes on past a bad view, or ends at it).
CallSource EnrollViews() {
  auto views = std::make_shared<std::vector<std::string>>();
  for (int h = 0; h < 8; ++h) views->push_back(Fixtures::View(3, 45 * h));
  return [views](int, Rng& rng) -> MessageSource {
    const bool skip_invalid = Chance(rng, 0.5);
    auto n = std::make_shared<size_t>(rng() % views->size());
    return [views, skip_invalid, n] {
      v1::EnrollViewRequest r;
      r.set_database(Fixtures::kEnrollDb);
      r.set_crossing(absl::StrCat("enrolled-", *n % 2));
      r.set_heading_deg(45.0 * static_cast<double>(*n % views->size()));
      r.mutable_image()->set_data((*views)[*n % views->size()]);
      r.mutable_image()->set_stamp(1000.0 + static_cast<double>(*n));
      r.set_create_crossing(true);
      r.set_store_image(*n % 3 == 0);
      r.set_skip_invalid(skip_invalid);
      r.set_position("north-kerb");
      ++*n;
      return Copy(r);
    };
  };
}

// A robot's queries of recognize-db: views between the enrolled headings, stamped in order.
CallSource Queries(Fixtures* fixtures) {
  auto images = std::make_shared<std::vector<std::string>>(
      std::vector<std::string>{Fixtures::View(1, 95), Fixtures::View(2, 185), Fixtures::View(1, 10)});
  return [fixtures, images](int thread, Rng& rng) -> MessageSource {
    const v1::RecognitionMode mode =
        Chance(rng, 0.5) ? v1::RECOGNITION_MODE_PAPER : v1::RECOGNITION_MODE_VERIFIED;
    auto n = std::make_shared<size_t>(rng() % images->size());
    return [fixtures, images, thread, mode, n] {
      v1::RecognizeRequest r;
      r.set_database(Fixtures::kRecognizeDb);
      r.mutable_image()->set_data((*images)[(*n)++ % images->size()]);
      r.mutable_image()->set_stamp(fixtures->NextStamp(thread));
      r.mutable_params()->set_mode(mode);
      r.mutable_params()->set_ratio(0.5);
      r.mutable_params()->set_n0(3);
      return Copy(r);
    };
  };
}

v1::SensorData CameraMessage(uint64_t sequence, double stamp, Rng& rng) {
  v1::SensorData data;
  data.set_sequence(sequence);
  v1::ImageFrame* frame = data.mutable_frame();
  frame->set_stamp(stamp);
  frame->set_image(Fixtures::CameraFrame(static_cast<int>(sequence)));
  if (Chance(rng, 0.5)) frame->set_depth(Fixtures::DepthFrame());
  if (Chance(rng, 0.3)) {
    frame->set_boxes_supplied(true);
    v1::BoundingBox* box = frame->add_boxes();
    box->set_x(20);
    box->set_y(30);
    box->set_width(40);
    box->set_height(60);
    box->set_label("person");
    box->set_confidence(0.9f);
  }
  return data;
}

// A stream of the thread's own session: a hello naming it, then odometry and scans of the room
// (laser, 70 % of the calls) or camera frames (visual), every stamp later than the last.
CallSource SensorStreams(Fixtures* fixtures) {
  return [fixtures](int thread, Rng& rng) -> MessageSource {
    const bool visual = Chance(rng, 0.3);
    const std::string session =
        visual ? fixtures->visual_session(thread) : fixtures->laser_session(thread);
    auto sequence = std::make_shared<uint64_t>(1);
    auto frame_rng = std::make_shared<Rng>(rng());
    return [fixtures, thread, visual, session, sequence, frame_rng]() -> std::unique_ptr<Message> {
      const uint64_t n = (*sequence)++;
      if (n == 1) {
        v1::SensorData hello;
        hello.set_session_id(session);
        hello.set_sequence(n);
        return Copy(hello);
      }
      const double stamp = fixtures->NextStamp(thread);
      if (visual) return Copy(CameraMessage(n, stamp, *frame_rng));
      const double x = 0.5 * std::sin(0.2 * stamp), theta = 0.1 * std::sin(0.1 * stamp);
      return Copy(n % 2 == 0 ? testing::Odom(n, stamp, x, 0, theta)
                             : testing::RoomScan(n, stamp, x, 0, theta));
    };
  };
}

// CreateSession: a mapping session with active exploration, a camera session, or localization
// on an imported map.
CallSource NewSessions(const std::string& map_session) {
  auto requests = std::make_shared<std::vector<v1::CreateSessionRequest>>(
      std::vector<v1::CreateSessionRequest>{ActiveLaserSession("hostile-creator"),
                                            VisualSession("hostile-creator"),
                                            LocalizationSession("hostile-creator", map_session)});
  return [requests](int, Rng& rng) -> MessageSource {
    const v1::CreateSessionRequest request = (*requests)[rng() % requests->size()];
    return [request] { return Copy(request); };
  };
}

template <class M>
M Parsed(const std::string& bytes) {
  M message;
  message.ParseFromString(bytes);
  return message;
}

// Hand-made sources and clean-ups, by the RPC's full name ("waymark.v1.SlamService.GetMap").
struct HandMade {
  using OnOk = std::function<void(const std::string&, const std::vector<std::string>&)>;
  HandMade(CallSource s, OnOk ok = nullptr, std::function<void()> after = nullptr)
      : source(std::move(s)), on_ok(std::move(ok)), after_batch(std::move(after)) {}
  CallSource source;
  OnOk on_ok;
  std::function<void()> after_batch;
};

std::map<std::string, HandMade> HandMadeTargets(Fixtures* f, const std::string& map_session) {
  using Answers = std::vector<std::string>;
  v1::CreateDatabaseRequest create_db;
  create_db.set_name("created-db");
  *create_db.mutable_params() = FixtureDatabaseParams();
  create_db.mutable_params()->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_VERIFIED);
  create_db.mutable_params()->set_keep_aspect(true);
  v1::AddCrossingRequest add_crossing;
  add_crossing.set_database(Fixtures::kEditDb);
  add_crossing.set_name("added-crossing");
  add_crossing.set_label("Main St / 2nd Ave, north-east corner");
  v1::DeleteCrossingRequest delete_crossing;
  delete_crossing.set_database(Fixtures::kEditDb);
  delete_crossing.set_name(Fixtures::kVictimCrossing);
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database(Fixtures::kRebuildDb);
  rebuild.set_cluster_threshold(5);
  v1::DeleteDatabaseRequest delete_db;
  delete_db.set_name(Fixtures::kVictimDb);
  v1::GetDatabaseStatsRequest stats;
  stats.set_name(Fixtures::kRecognizeDb);
  v1::ListCrossingsRequest list_crossings;
  list_crossings.set_database(Fixtures::kRecognizeDb);
  v1::GetMapRequest get_map;
  get_map.set_session_id(f->read_session());
  v1::GetTrajectoryRequest get_trajectory;
  get_trajectory.set_session_id(f->read_session());
  v1::GetOccupancyGridRequest get_grid;
  get_grid.set_session_id(f->read_session());
  get_grid.set_resolution(0.05);
  v1::CloseSessionRequest close;
  close.set_session_id(f->victim_close_session());
  v1::DeleteSessionRequest delete_session;
  delete_session.set_session_id(f->victim_delete_session());
  delete_session.set_force(true);
  v1::ListSessionsRequest list_sessions;
  list_sessions.set_robot_id("hostile-robot-0");
  v1::CreateTokenRequest create_token;
  create_token.set_name("created-token");
  create_token.set_robot_id("hostile-robot-9");
  create_token.set_role(v1::ROBOT);
  create_token.set_expires_in_seconds(3600);
  v1::RevokeTokenRequest revoke;
  revoke.set_name(Fixtures::kVictimToken);
  grpc::health::v1::HealthCheckRequest check;
  check.set_service("waymark.v1.SlamService");

  const auto delete_session_answer = [f](const std::string&, const Answers& answers) {
    if (!answers.empty()) f->DeleteSession(Parsed<v1::Session>(answers[0]).session_id());
  };
  const auto reset_enroll_db = [f] { f->ResetDatabase(Fixtures::kEnrollDb); };
  return {
      {"waymark.v1.CrossingService.CreateDatabase",
       {Always(create_db),
        [f](const std::string&, const Answers& answers) {
          if (!answers.empty()) f->DeleteDatabase(Parsed<v1::CrossingDatabase>(answers[0]).name());
        }}},
      {"waymark.v1.CrossingService.ListDatabases", {Always(v1::ListDatabasesRequest())}},
      {"waymark.v1.CrossingService.DeleteDatabase", {Always(delete_db)}},
      {"waymark.v1.CrossingService.GetDatabaseStats", {Always(stats)}},
      {"waymark.v1.CrossingService.AddCrossing",
       {Always(add_crossing),
        [f](const std::string& request, const Answers& answers) {
          if (answers.empty()) return;
          f->DeleteCrossing(Parsed<v1::AddCrossingRequest>(request).database(),
                            Parsed<v1::Crossing>(answers[0]).name());
        }}},
      {"waymark.v1.CrossingService.ListCrossings", {Always(list_crossings)}},
      {"waymark.v1.CrossingService.DeleteCrossing", {Always(delete_crossing)}},
      {"waymark.v1.CrossingService.EnrollView", {EnrollViews(), nullptr, reset_enroll_db}},
      {"waymark.v1.CrossingService.BulkEnroll", {EnrollViews(), nullptr, reset_enroll_db}},
      {"waymark.v1.CrossingService.StreamEnroll", {EnrollViews(), nullptr, reset_enroll_db}},
      {"waymark.v1.CrossingService.RebuildClusters", {Always(rebuild)}},
      {"waymark.v1.CrossingService.RecognizeCrossing", {Queries(f)}},
      {"waymark.v1.CrossingService.StreamRecognize", {Queries(f)}},
      {"waymark.v1.SlamService.CreateSession", {NewSessions(map_session), delete_session_answer}},
      {"waymark.v1.SlamService.StreamSensorData", {SensorStreams(f)}},
      {"waymark.v1.SlamService.GetMap", {Always(get_map)}},
      {"waymark.v1.SlamService.GetTrajectory", {Always(get_trajectory)}},
      {"waymark.v1.SlamService.CloseSession", {Always(close)}},
      {"waymark.v1.SlamService.ListSessions", {Always(list_sessions)}},
      {"waymark.v1.SlamService.DeleteSession", {Always(delete_session)}},
      {"waymark.v1.SlamService.GetOccupancyGrid", {Always(get_grid)}},
      {"waymark.v1.SlamService.ImportMap",
       {Always(ImportRequest("hostile-importer", "imported room")), delete_session_answer}},
      {"waymark.v1.TokenService.CreateToken", {Always(create_token)}},
      {"waymark.v1.TokenService.ListTokens", {Always(v1::ListTokensRequest())}},
      {"waymark.v1.TokenService.RevokeToken", {Always(revoke)}},
      {"grpc.health.v1.Health.Check", {Always(check)}},
      {"grpc.health.v1.Health.Watch", {Always(grpc::health::v1::HealthCheckRequest())}},
  };
}

// The files whose services are attacked: every service in them, every method of each.
std::vector<const google::protobuf::FileDescriptor*> ServiceFiles() {
  return {v1::CrossingDatabase::descriptor()->file(), v1::Session::descriptor()->file(),
          v1::Token::descriptor()->file(), grpc::health::v1::HealthCheckRequest::descriptor()->file()};
}

RpcKind KindOf(const MethodDescriptor* method) {
  if (method->client_streaming()) {
    return method->server_streaming() ? RpcKind::kBidiStream : RpcKind::kClientStream;
  }
  return method->server_streaming() ? RpcKind::kServerStream : RpcKind::kUnary;
}

template <class Call>
void Cleanup(std::atomic<int>& failed, Call call) {
  if (!call().ok()) ++failed;
}

}  // namespace

std::string KindName(RpcKind kind) {
  switch (kind) {
    case RpcKind::kUnary: return "unary";
    case RpcKind::kClientStream: return "client stream";
    case RpcKind::kServerStream: return "server stream";
    case RpcKind::kBidiStream: return "bidi stream";
  }
  return "?";
}

v1::DatabaseParams FixtureDatabaseParams() {
  v1::DatabaseParams params;
  params.set_work_width(160);
  params.set_work_height(120);
  params.set_max_keypoints(300);
  params.set_cluster_threshold(5);
  params.mutable_recognition()->set_mode(v1::RECOGNITION_MODE_PAPER);
  return params;
}

Fixtures::Fixtures(std::shared_ptr<grpc::Channel> channel, int threads)
    : channel_(std::move(channel)), stamps_(new std::atomic<int64_t>[threads]) {
  for (int t = 0; t < threads; ++t) stamps_[t] = 0;
}

std::string Fixtures::View(int crossing, double heading) {
  static std::mutex mutex;
  static std::map<int, cv::Mat> panoramas;  // generating one takes a while; views reuse it
  std::lock_guard<std::mutex> lock(mutex);
  auto [it, added] = panoramas.try_emplace(crossing);
  if (added) it->second = testing::MakePanorama(static_cast<uint32_t>(crossing));
  return testing::EncodeJpeg(testing::CropView(it->second, heading));
}

std::string Fixtures::CameraFrame(int index) {
  static const auto* frames = [] {
    auto* encoded = new std::vector<std::string>();
    const cv::Mat panorama = testing::MakePanorama(40);
    for (int i = 0; i < 16; ++i) {
      encoded->push_back(testing::EncodePng(testing::CropView(panorama, 2.0 * i, 60, 160, 120)));
    }
    return encoded;
  }();
  return (*frames)[static_cast<size_t>(index) % frames->size()];
}

std::string Fixtures::DepthFrame() {
  static const std::string* depth = [] {
    std::vector<uchar> bytes;
    cv::imencode(".png", cv::Mat(120, 160, CV_16UC1, cv::Scalar(10000)), bytes);  // 2 m
    return new std::string(bytes.begin(), bytes.end());
  }();
  return *depth;
}

v1::CreateSessionRequest Fixtures::LaserSession(const std::string& robot) {
  v1::CreateSessionRequest r = testing::TestSessionRequest(robot);
  r.mutable_laser()->mutable_params()->set_max_range(6);
  r.mutable_laser()->mutable_params()->set_loop_closure(true);
  return r;
}

v1::RecognizeRequest Fixtures::KnownQuery() const {
  v1::RecognizeRequest r;
  r.set_database(kRecognizeDb);
  r.mutable_image()->set_data(View(1, 90));
  return r;
}

absl::Status Fixtures::CreateCrossingDatabases() {
  client::CrossingClient crossing(channel_);
  for (const char* name : {kRecognizeDb, kEnrollDb, kEditDb, kVictimDb, kRebuildDb}) {
    v1::CreateDatabaseRequest create;
    create.set_name(name);
    *create.mutable_params() = FixtureDatabaseParams();
    if (auto created = crossing.CreateDatabase(create); !created.ok()) return created.status();
  }
  const auto enroll = [&](const char* db, int c, double heading) {
    v1::EnrollViewRequest r;
    r.set_database(db);
    r.set_crossing(absl::StrCat("crossing-", c));
    r.set_heading_deg(heading);
    r.set_create_crossing(true);
    r.mutable_image()->set_data(View(c, heading));
    return crossing.EnrollView(r).status();
  };
  for (int c : {1, 2}) {
    for (double heading : {0, 90, 180, 270}) {
      if (absl::Status s = enroll(kRecognizeDb, c, heading); !s.ok()) return s;
    }
  }
  for (double heading : {0, 120, 240}) {
    if (absl::Status s = enroll(kRebuildDb, 3, heading); !s.ok()) return s;
  }
  for (const char* name : {kVictimCrossing, "kept-crossing"}) {
    v1::AddCrossingRequest add;
    add.set_database(kEditDb);
    add.set_name(name);
    if (auto added = crossing.AddCrossing(add); !added.ok()) return added.status();
  }
  return absl::OkStatus();
}

absl::Status Fixtures::CreateSessions(int threads) {
  client::SlamClient slam(channel_);
  const auto create = [&](const v1::CreateSessionRequest& request, std::string* id) {
    absl::StatusOr<v1::Session> session = slam.CreateSession(request);
    if (session.ok()) *id = session->session_id();
    return session.status();
  };
  laser_sessions_.resize(threads);
  visual_sessions_.resize(threads);
  for (int t = 0; t < threads; ++t) {
    const std::string robot = absl::StrCat("hostile-robot-", t);
    if (absl::Status s = create(LaserSession(robot), &laser_sessions_[t]); !s.ok()) return s;
    if (absl::Status s = create(VisualSession(robot), &visual_sessions_[t]); !s.ok()) return s;
  }
  for (auto [robot, id] : {std::pair{"hostile-reader", &read_session_},
                           std::pair{"hostile-closer", &victim_close_},
                           std::pair{"hostile-deleter", &victim_delete_}}) {
    if (absl::Status s = create(LaserSession(robot), id); !s.ok()) return s;
  }
  // The read session gets a trajectory and a map, so GetMap and friends have something to send.
  std::unique_ptr<client::SensorStream> stream = slam.StreamSensorData(read_session_);
  for (int i = 0; i < 40; ++i) {
    const double stamp = 1.0 + 0.5 * i, x = 0.02 * i;
    if (!stream->SendOdometry(testing::Odom(0, stamp, x, 0, 0).odometry()).ok() ||
        !stream->SendScan(testing::RoomScan(0, stamp + 0.01, x, 0, 0).scan()).ok()) {
      break;
    }
  }
  if (absl::Status s = stream->WaitIdle(absl::Seconds(60)); !s.ok()) return s;
  return stream->Finish();
}

absl::StatusOr<std::unique_ptr<Fixtures>> Fixtures::Create(std::shared_ptr<grpc::Channel> channel,
                                                          int threads) {
  std::unique_ptr<Fixtures> fixtures(new Fixtures(std::move(channel), threads));
  if (absl::Status s = fixtures->CreateCrossingDatabases(); !s.ok()) return s;
  if (absl::Status s = fixtures->CreateSessions(threads); !s.ok()) return s;
  auto token = client::TokenClient(fixtures->channel_)
                   .CreateToken(kVictimToken, "victim-robot", v1::ROBOT, absl::ZeroDuration());
  if (!token.ok()) return token.status();
  return fixtures;
}

void Fixtures::ResetDatabase(const std::string& database) {
  DeleteDatabase(database);
  v1::CreateDatabaseRequest create;
  create.set_name(database);
  *create.mutable_params() = FixtureDatabaseParams();
  Cleanup(cleanups_failed_, [&] { return client::CrossingClient(channel_).CreateDatabase(create).status(); });
}

void Fixtures::DeleteDatabase(const std::string& name) {
  v1::DeleteDatabaseRequest request;
  request.set_name(name);
  Cleanup(cleanups_failed_, [&] { return client::CrossingClient(channel_).DeleteDatabase(request).status(); });
}

void Fixtures::DeleteCrossing(const std::string& database, const std::string& name) {
  v1::DeleteCrossingRequest request;
  request.set_database(database);
  request.set_name(name);
  Cleanup(cleanups_failed_, [&] { return client::CrossingClient(channel_).DeleteCrossing(request).status(); });
}

void Fixtures::DeleteSession(const std::string& id) {
  Cleanup(cleanups_failed_, [&] { return client::SlamClient(channel_).DeleteSession(id, true).status(); });
}

std::vector<RpcTarget> EnumerateTargets(Fixtures& fixtures) {
  // A closed map for the localization sessions CreateSession's requests ask for.
  absl::StatusOr<v1::Session> map = client::SlamClient(fixtures.channel())
                                        .ImportMap("hostile-mapper", "campaign map", RoomGrid());
  const std::map<std::string, HandMade> hand_made =
      HandMadeTargets(&fixtures, map.ok() ? map->session_id() : "no-map");
  std::vector<RpcTarget> targets;
  for (const google::protobuf::FileDescriptor* file : ServiceFiles()) {
    for (int s = 0; s < file->service_count(); ++s) {
      const google::protobuf::ServiceDescriptor* service = file->service(s);
      for (int m = 0; m < service->method_count(); ++m) {
        const MethodDescriptor* method = service->method(m);
        RpcTarget target;
        target.method = method;
        target.path = absl::StrCat("/", service->full_name(), "/", method->name());
        target.name = absl::StrCat(service->name(), "/", method->name());
        target.kind = KindOf(method);
        const auto found = hand_made.find(method->full_name());
        target.hand_made = found != hand_made.end();
        target.begin_call = target.hand_made ? found->second.source : Generic(method);
        if (target.hand_made) {
          target.on_ok = found->second.on_ok;
          target.after_batch = found->second.after_batch;
        }
        targets.push_back(std::move(target));
      }
    }
  }
  return targets;
}

}  // namespace waymark::bench::hostile
