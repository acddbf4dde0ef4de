// Fuzz target crossing_requests: the request of every unary CrossingService RPC (the streams
// BulkEnroll, StreamEnroll and StreamRecognize take the same EnrollViewRequest and RecognizeRequest
// and hand them to the same registry calls), served by the real CrossingServiceImpl over a
// CrossingRegistry on an in-memory SQLite store: names, headings, positions, database and
// recognition parameters, image decoding and feature extraction, enrollment and recognition.
//
// The registry is made once per process with database "fuzz" (crossings "a", two views, and "b",
// none) at a 64x48 working resolution, so that a request that gets as far as SIFT costs about a
// millisecond. After each input the state is put back: databases an input created are deleted,
// and the fixture database is rebuilt when an input changed it, so every input meets the same
// state whatever ran before it.
//
// Oracle beyond "no crash": the parameters a created database reports must read back unchanged
// from the JSON it is stored as (else it would not load after a restart).

#include <memory>
#include <string>
#include <vector>

#include "server/service/auth/authenticator.h"
#include "server/service/crossing/crossing_registry.h"
#include "server/service/crossing_service.h"
#include "server/service/crossing/params.h"
#include "storage/crossing_store.h"
#include "tests/fuzz/fuzz_images.h"
#include "tests/fuzz/fuzz_targets.h"
#include "tests/fuzz/service_calls.h"

namespace waymark::fuzz {
namespace {

using service::CrossingServiceImpl;

constexpr char kDatabase[] = "fuzz";

v1::DatabaseParams FixtureParams() {
  v1::DatabaseParams params;
  params.set_work_width(kViewWidth);
  params.set_work_height(kViewHeight);
  return params;
}

v1::EnrollViewRequest Enroll(const std::string& crossing, double heading, std::string image) {
  v1::EnrollViewRequest request;
  request.set_database(kDatabase);
  request.set_crossing(crossing);
  request.set_heading_deg(heading);
  request.set_create_crossing(true);
  request.mutable_image()->set_data(std::move(image));
  return request;
}

// A created database's parameters must survive the JSON they are stored as.
void CheckStoredParams(const v1::CreateDatabaseRequest&, const v1::CrossingDatabase& created) {
  absl::StatusOr<v1::DatabaseParams> loaded =
      service::ParamsFromJson(service::ParamsToJson(created.params()));
  Require(loaded.status(), "a created database's params read back from their JSON");
  Require(loaded->SerializeAsString() == created.params().SerializeAsString(),
          "a created database's params change through their JSON");
}

class CrossingFixture {
 public:
  CrossingFixture() {
    QuietLogs();
    auto store = storage::OpenSqliteCrossingStore(":memory:");
    Require(store.status(), "opening an in-memory crossing store");
    auto registry = service::CrossingRegistry::Load(*std::move(store));
    Require(registry.status(), "loading the crossing registry");
    registry_ = *std::move(registry);
    // Unary calls only: no stream limiter or idle reaper is used.
    service_ =
        std::make_unique<CrossingServiceImpl>(registry_.get(), auth_.get(), nullptr, nullptr);
    CrossingServiceImpl* s = service_.get();
    rpcs_ = {
        UnaryRpc(s, &CrossingServiceImpl::CreateDatabase, CheckStoredParams),
        UnaryRpc(s, &CrossingServiceImpl::ListDatabases),
        UnaryRpc(s, &CrossingServiceImpl::DeleteDatabase),
        UnaryRpc(s, &CrossingServiceImpl::GetDatabaseStats),
        UnaryRpc(s, &CrossingServiceImpl::AddCrossing),
        UnaryRpc(s, &CrossingServiceImpl::ListCrossings),
        UnaryRpc(s, &CrossingServiceImpl::DeleteCrossing),
        UnaryRpc(s, &CrossingServiceImpl::EnrollView),
        UnaryRpc(s, &CrossingServiceImpl::RebuildClusters),
        UnaryRpc(s, &CrossingServiceImpl::RecognizeCrossing),
    };
    Build();
  }

  void Run(const RequestInput& input) {
    rpcs_[input.rpc % rpcs_.size()](input);
    Restore();
  }

 private:
  // The fixture is made and put back through the registry, whose errors say what went wrong.
  void Build() {
    v1::CreateDatabaseRequest create;
    create.set_name(kDatabase);
    *create.mutable_params() = FixtureParams();
    Require(registry_->CreateDatabase(create).status(), "creating the fixture database");
    for (double heading : {0.0, 90.0}) {
      Require(
          registry_->EnrollView(Enroll("a", heading, adapters::EncodeJpeg(FuzzView(1, heading))))
              .status(),
          "enrolling the fixture's views");
    }
    v1::AddCrossingRequest add;
    add.set_database(kDatabase);
    add.set_name("b");
    Require(registry_->AddCrossing(add).status(), "adding the fixture's empty crossing");
    absl::StatusOr<v1::DatabaseStats> stats = registry_->GetStats(kDatabase);
    Require(stats.status(), "reading the fixture database");
    baseline_ = stats->SerializeAsString();
  }

  void Restore() {
    absl::StatusOr<v1::ListDatabasesResponse> all = registry_->ListDatabases();
    Require(all.status(), "listing databases");
    for (const v1::CrossingDatabase& db : all->databases()) {
      if (db.name() == kDatabase) continue;
      Require(registry_->DeleteDatabase(db.name()), "deleting a database an input created");
    }
    absl::StatusOr<v1::DatabaseStats> stats = registry_->GetStats(kDatabase);
    if (stats.ok() && stats->SerializeAsString() == baseline_) return;
    if (stats.ok()) Require(registry_->DeleteDatabase(kDatabase), "deleting the changed fixture");
    Build();
  }

  std::unique_ptr<service::Authenticator> auth_ = service::Authenticator::AuthOff();
  std::unique_ptr<service::CrossingRegistry> registry_;
  std::unique_ptr<CrossingServiceImpl> service_;
  std::vector<RpcHandler> rpcs_;
  std::string baseline_;  // the fixture database's DatabaseStats
};

void CrossingRequests(const uint8_t* data, size_t size) {
  // Never destroyed: its registry's threads must not be stopped by static destructors.
  static CrossingFixture* fixture = new CrossingFixture;
  if (std::optional<RequestInput> input = SplitRequestInput(data, size)) fixture->Run(*input);
}

std::vector<std::string> CrossingSeeds() {
  const std::string known = adapters::EncodeJpeg(FuzzView(1, 0));  // a stored view: DUPLICATE
  const std::string jpeg = adapters::EncodeJpeg(FuzzView(1, 180));
  const std::string png = adapters::EncodePng(FuzzView(2, 45));
  std::vector<std::string> seeds;

  v1::CreateDatabaseRequest create;
  create.set_name("db-2.x_y");
  *create.mutable_params() = FixtureParams();
  create.mutable_params()->set_keep_aspect(true);
  create.mutable_params()->set_max_keypoints(50);
  v1::RecognitionParams* recognition = create.mutable_params()->mutable_recognition();
  recognition->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
  recognition->set_ratio(0.5);
  recognition->set_alpha(0.25);
  recognition->set_beta(0.75);
  recognition->set_evidence_threshold(0.9);
  seeds.push_back(RequestSeed(0, create));
  seeds.push_back(RequestSeed(1, v1::ListDatabasesRequest()));
  v1::DeleteDatabaseRequest drop;
  drop.set_name(kDatabase);
  seeds.push_back(RequestSeed(2, drop));
  v1::GetDatabaseStatsRequest stats;
  stats.set_name(kDatabase);
  seeds.push_back(RequestSeed(3, stats));
  v1::AddCrossingRequest add;
  add.set_database(kDatabase);
  add.set_name("Main St / 5th Ave");
  add.set_label("north-east corner");
  seeds.push_back(RequestSeed(4, add));
  v1::ListCrossingsRequest list;
  list.set_database(kDatabase);
  seeds.push_back(RequestSeed(5, list));
  v1::DeleteCrossingRequest remove;
  remove.set_database(kDatabase);
  remove.set_name("a");
  seeds.push_back(RequestSeed(6, remove));
  seeds.push_back(RequestSeed(7, Enroll("a", 0, known)));
  v1::EnrollViewRequest replace = Enroll("a", 180, jpeg);
  replace.set_replace(true);
  replace.set_position("north-kerb");
  replace.set_store_image(true);
  seeds.push_back(RequestSeed(7, replace));
  seeds.push_back(RequestSeed(7, Enroll("c", 359.5, png)));
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database(kDatabase);
  rebuild.set_cluster_threshold(3);
  seeds.push_back(RequestSeed(8, rebuild));
  for (v1::RecognitionMode mode : {v1::RECOGNITION_MODE_PAPER, v1::RECOGNITION_MODE_VERIFIED,
                                   v1::RECOGNITION_MODE_RETRIEVAL}) {
    v1::RecognizeRequest recognize;
    recognize.set_database(kDatabase);
    recognize.mutable_image()->set_data(adapters::EncodeJpeg(FuzzView(1, 10)));
    recognize.mutable_image()->set_stamp(12.5);
    recognize.mutable_params()->set_mode(mode);
    recognize.mutable_params()->set_n0(2);
    recognize.mutable_params()->set_n1(3);
    recognize.mutable_params()->set_min_inliers(4);
    seeds.push_back(RequestSeed(9, recognize));
  }
  return seeds;
}

}  // namespace

FuzzTarget CrossingRequestsTarget() {
  return {"crossing_requests", CrossingRequests, CrossingSeeds};
}

}  // namespace waymark::fuzz
