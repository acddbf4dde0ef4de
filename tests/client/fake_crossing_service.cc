#include "tests/client/fake_crossing_service.h"

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <thread>

namespace waymark::testing {
namespace {

grpc::Status NoDatabase(const std::string& name) {
  return grpc::Status(grpc::StatusCode::NOT_FOUND, "no crossing database named '" + name + "'");
}

}  // namespace

void FakeCrossingService::FailNextWithUnavailable(const std::string& method, int times) {
  std::lock_guard<std::mutex> lock(mutex_);
  failures_[method] = times;
}

int FakeCrossingService::calls(const std::string& method) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = calls_.find(method);
  return it == calls_.end() ? 0 : it->second;
}

void FakeCrossingService::set_on_enroll(std::function<void(int index)> hook) {
  std::lock_guard<std::mutex> lock(mutex_);
  on_enroll_ = std::move(hook);
}

void FakeCrossingService::set_on_recognize(RecognizeHook hook) {
  std::lock_guard<std::mutex> lock(mutex_);
  on_recognize_ = std::move(hook);
}

std::vector<FakeCrossingService::View> FakeCrossingService::views(
    const std::string& database) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = databases_.find(database);
  return it == databases_.end() ? std::vector<View>() : it->second.views;
}

v1::CreateDatabaseRequest FakeCrossingService::last_create() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_create_;
}

v1::RecognitionParams FakeCrossingService::last_params() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_params_;
}

std::vector<std::pair<int, int>> FakeCrossingService::stream_frame_sizes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stream_frame_sizes_;
}

grpc::Status FakeCrossingService::Enter(const std::string& method) {
  absl::Duration delay;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++calls_[method];
    delay = delay_;
    if (failures_[method] > 0) {
      --failures_[method];
      return grpc::Status(grpc::StatusCode::UNAVAILABLE, "injected outage");
    }
  }
  std::this_thread::sleep_for(absl::ToChronoNanoseconds(delay));
  return grpc::Status::OK;
}

FakeCrossingService::Database* FakeCrossingService::Find(const std::string& name) {
  auto it = databases_.find(name);
  return it == databases_.end() ? nullptr : &it->second;
}

v1::CrossingDatabase FakeCrossingService::Summary(const Database& db) const {
  v1::CrossingDatabase info = db.info;
  info.set_crossings(static_cast<int>(db.crossings.size()));
  info.set_views(static_cast<int>(db.views.size()));
  info.set_clusters(static_cast<int>(db.crossings.size()));  // one cluster per crossing
  return info;
}

grpc::Status FakeCrossingService::CreateDatabase(grpc::ServerContext*,
                                                 const v1::CreateDatabaseRequest* request,
                                                 v1::CrossingDatabase* response) {
  if (auto s = Enter("CreateDatabase"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  last_create_ = *request;
  if (request->name().empty()) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "database name is empty");
  }
  if (Find(request->name()) != nullptr) {
    return grpc::Status(grpc::StatusCode::ALREADY_EXISTS,
                        "database '" + request->name() + "' already exists");
  }
  Database& db = databases_[request->name()];
  db.info.set_id(next_id_++);
  db.info.set_name(request->name());
  db.info.set_created_at(1700000000);
  v1::DatabaseParams* params = db.info.mutable_params();
  *params = request->params();
  if (!params->has_work_width()) params->set_work_width(320);
  if (!params->has_work_height()) params->set_work_height(240);
  if (!params->has_hue_bins()) params->set_hue_bins(36);
  if (!params->has_cluster_threshold()) params->set_cluster_threshold(5);
  if (!params->has_max_keypoints()) params->set_max_keypoints(0);
  if (!params->recognition().has_mode()) {
    params->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_PAPER);
  }
  *response = Summary(db);
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::ListDatabases(grpc::ServerContext*,
                                                const v1::ListDatabasesRequest*,
                                                v1::ListDatabasesResponse* response) {
  if (auto s = Enter("ListDatabases"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [name, db] : databases_) *response->add_databases() = Summary(db);
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::DeleteDatabase(grpc::ServerContext*,
                                                 const v1::DeleteDatabaseRequest* request,
                                                 v1::DeleteDatabaseResponse*) {
  if (auto s = Enter("DeleteDatabase"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  if (databases_.erase(request->name()) == 0) return NoDatabase(request->name());
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::GetDatabaseStats(grpc::ServerContext*,
                                                   const v1::GetDatabaseStatsRequest* request,
                                                   v1::DatabaseStats* response) {
  if (auto s = Enter("GetDatabaseStats"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  Database* db = Find(request->name());
  if (db == nullptr) return NoDatabase(request->name());
  *response->mutable_database() = Summary(*db);
  response->set_keypoints(int64_t{kKeypointsPerView} * static_cast<int64_t>(db->views.size()));
  response->set_descriptor_bytes(response->keypoints() * 128);
  int64_t cluster_id = 1;
  for (const auto& [name, crossing] : db->crossings) {
    *response->add_crossing_list() = crossing;
    v1::ClusterInfo* cluster = response->add_clusters();
    cluster->set_id(cluster_id++);
    cluster->set_center_view_id(crossing.id());
    cluster->set_members(crossing.views());
  }
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::AddCrossing(grpc::ServerContext*,
                                              const v1::AddCrossingRequest* request,
                                              v1::Crossing* response) {
  if (auto s = Enter("AddCrossing"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  Database* db = Find(request->database());
  if (db == nullptr) return NoDatabase(request->database());
  if (db->crossings.count(request->name()) > 0) {
    return grpc::Status(grpc::StatusCode::ALREADY_EXISTS, "crossing exists");
  }
  v1::Crossing& crossing = db->crossings[request->name()];
  crossing.set_id(next_id_++);
  crossing.set_name(request->name());
  crossing.set_label(request->label());
  *response = crossing;
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::ListCrossings(grpc::ServerContext*,
                                                const v1::ListCrossingsRequest* request,
                                                v1::ListCrossingsResponse* response) {
  if (auto s = Enter("ListCrossings"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  Database* db = Find(request->database());
  if (db == nullptr) return NoDatabase(request->database());
  for (const auto& [name, crossing] : db->crossings) *response->add_crossings() = crossing;
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::DeleteCrossing(grpc::ServerContext*,
                                                 const v1::DeleteCrossingRequest* request,
                                                 v1::DeleteCrossingResponse* response) {
  if (auto s = Enter("DeleteCrossing"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  Database* db = Find(request->database());
  if (db == nullptr) return NoDatabase(request->database());
  auto it = db->crossings.find(request->name());
  if (it == db->crossings.end()) return grpc::Status(grpc::StatusCode::NOT_FOUND, "no crossing");
  response->set_views_deleted(it->second.views());
  db->crossings.erase(it);
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::EnrollOne(const v1::EnrollViewRequest& request,
                                            v1::EnrollViewResponse* answer) {
  std::lock_guard<std::mutex> lock(mutex_);
  Database* db = Find(request.database());
  if (db == nullptr) return NoDatabase(request.database());
  const std::string& bytes = request.image().data();
  auto same_place = [&](const View& v) {
    return v.crossing == request.crossing() && v.heading_deg == request.heading_deg() &&
           v.position == request.position();
  };
  for (const View& view : db->views) {
    if (view.bytes != bytes || (request.replace() && !same_place(view))) continue;
    answer->set_outcome(v1::ENROLL_OUTCOME_DUPLICATE);
    answer->set_view_id(view.id);
    answer->set_crossing(view.crossing);
    answer->set_heading_deg(view.heading_deg);
    answer->set_heading_unknown(view.heading_unknown);
    answer->set_position(view.position);
    return grpc::Status::OK;
  }
  if (bytes.empty()) {
    if (!request.skip_invalid()) {
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "the image is empty");
    }
    answer->set_outcome(v1::ENROLL_OUTCOME_INVALID);
    answer->set_error_code(grpc::StatusCode::INVALID_ARGUMENT);
    answer->set_error_message("the image is empty");
    return grpc::Status::OK;
  }
  auto crossing = db->crossings.find(request.crossing());
  if (crossing == db->crossings.end()) {
    if (!request.create_crossing()) {
      return grpc::Status(grpc::StatusCode::NOT_FOUND, "no crossing " + request.crossing());
    }
    crossing = db->crossings.emplace(request.crossing(), v1::Crossing()).first;
    crossing->second.set_id(next_id_++);
    crossing->second.set_name(request.crossing());
    answer->set_crossing_created(true);
    answer->set_new_cluster(true);
  }
  if (request.replace()) {
    auto replaced = [&](const View& v) { return same_place(v) || v.bytes == bytes; };
    for (const View& view : db->views) {
      if (!replaced(view)) continue;
      answer->add_replaced_view_ids(view.id);
      v1::Crossing& owner = db->crossings[view.crossing];
      owner.set_views(owner.views() - 1);
    }
    db->views.erase(std::remove_if(db->views.begin(), db->views.end(), replaced),
                    db->views.end());
  }
  crossing->second.set_views(crossing->second.views() + 1);
  const int64_t id = next_id_++;
  db->views.push_back(
      {request.crossing(), request.heading_deg(), bytes, request.store_image(), id,
       request.position(), request.heading_unknown()});
  answer->set_outcome(v1::ENROLL_OUTCOME_STORED);
  answer->set_view_id(id);
  answer->set_crossing_id(crossing->second.id());
  answer->set_crossing(request.crossing());
  answer->set_heading_deg(request.heading_deg());
  answer->set_heading_unknown(request.heading_unknown());
  answer->set_position(request.position());
  answer->set_keypoints(kKeypointsPerView);
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::BulkEnroll(grpc::ServerContext*,
                                             grpc::ServerReader<v1::EnrollViewRequest>* reader,
                                             v1::BulkEnrollResponse* response) {
  if (auto s = Enter("BulkEnroll"); !s.ok()) return s;
  v1::EnrollViewRequest request;
  while (reader->Read(&request)) {
    v1::EnrollViewResponse answer;
    if (grpc::Status s = EnrollOne(request, &answer); !s.ok()) return s;
    response->set_crossings_created(response->crossings_created() +
                                    (answer.crossing_created() ? 1 : 0));
    response->set_clusters_created(response->clusters_created() + (answer.new_cluster() ? 1 : 0));
    switch (answer.outcome()) {
      case v1::ENROLL_OUTCOME_DUPLICATE:
        response->set_duplicates(response->duplicates() + 1);
        break;
      case v1::ENROLL_OUTCOME_INVALID:
        response->add_skipped()->set_reason(answer.error_message());
        break;
      default:
        response->set_views(response->views() + 1);
        response->set_keypoints(response->keypoints() + answer.keypoints());
        break;
    }
  }
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::StreamEnroll(
    grpc::ServerContext*,
    grpc::ServerReaderWriter<v1::EnrollViewResponse, v1::EnrollViewRequest>* stream) {
  if (auto s = Enter("StreamEnroll"); !s.ok()) return s;
  std::function<void(int)> hook;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    hook = on_enroll_;
  }
  v1::EnrollViewRequest request;
  for (int index = 0; stream->Read(&request); ++index) {
    if (hook) hook(index);
    v1::EnrollViewResponse answer;
    if (grpc::Status s = EnrollOne(request, &answer); !s.ok()) return s;
    answer.set_index(index);
    if (!stream->Write(answer)) break;
  }
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::RecognizeCrossing(grpc::ServerContext*,
                                                    const v1::RecognizeRequest* request,
                                                    v1::RecognizeResponse* response) {
  if (auto s = Enter("RecognizeCrossing"); !s.ok()) return s;
  std::lock_guard<std::mutex> lock(mutex_);
  last_params_ = request->params();
  Database* db = Find(request->database());
  if (db == nullptr) return NoDatabase(request->database());
  response->set_keypoints(kKeypointsPerView);
  response->set_mode(v1::RECOGNITION_MODE_PAPER);
  response->mutable_timings()->set_total_ms(1.5);
  for (size_t i = 0; i < db->views.size(); ++i) {
    const View& view = db->views[i];
    if (view.bytes != request->image().data()) continue;
    response->set_recognized(true);
    response->set_crossing(view.crossing);
    response->set_view_id(view.id);
    response->set_heading_deg(view.heading_deg);
    response->set_position(view.position);
    response->set_decision(0.9);
    v1::Candidate* candidate = response->add_candidates();
    candidate->set_view_id(response->view_id());
    candidate->set_crossing(view.crossing);
    candidate->set_heading_deg(view.heading_deg);
    candidate->set_position(view.position);
    candidate->set_matches(kKeypointsPerView);
    candidate->set_kept(true);
    candidate->set_similarity(0.8);
    candidate->set_decision(0.9);
    break;
  }
  if (!response->recognized()) response->set_reason("no view matches");
  if (on_recognize_) on_recognize_(*request, response);
  return grpc::Status::OK;
}

grpc::Status FakeCrossingService::StreamRecognize(
    grpc::ServerContext*,
    grpc::ServerReaderWriter<v1::RecognizeResponse, v1::RecognizeRequest>* stream) {
  if (auto s = Enter("StreamRecognize"); !s.ok()) return s;
  v1::RecognizeRequest request;
  for (int64_t frame = 0; stream->Read(&request); ++frame) {
    const std::string& data = request.image().data();
    cv::Mat image = cv::imdecode(std::vector<uchar>(data.begin(), data.end()), cv::IMREAD_COLOR);
    if (image.empty()) {
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "frame is not an image");
    }
    v1::RecognizeResponse response;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (Find(request.database()) == nullptr) return NoDatabase(request.database());
      stream_frame_sizes_.emplace_back(image.cols, image.rows);
      if (frame >= stream_recognize_from_) {
        response.set_recognized(true);
        response.set_crossing("A");
        response.set_heading_deg(30);
      } else {
        response.set_reason("too few matches");
      }
    }
    response.set_frame_index(frame);
    response.set_stamp(request.image().stamp());
    if (!stream->Write(response)) break;
  }
  return grpc::Status::OK;
}

FakeServer::FakeServer() {
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service_);
  server_ = builder.BuildAndStart();
  address_ = "127.0.0.1:" + std::to_string(port);
}

FakeServer::~FakeServer() { server_->Shutdown(); }

}  // namespace waymark::testing
