#include "server/service/crossing_service.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <future>
#include <memory>
#include <optional>
#include <thread>

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"
#include "server/service/runtime/grpc_status.h"
#include "server/service/service_call.h"
#include "server/service/crossing/stream_evidence.h"

namespace waymark::service {
namespace {

// A skipped view's crossing and position are echoed whole up to this many characters: every
// valid value (crossing names have at most 128, positions 64), never a client's megabyte.
constexpr size_t kMaxEchoedChars = 128;

// The views of an enrollment stream, in stream order, with up to `depth` of them being prepared
// (hashed, features extracted) ahead on their own threads while the handler commits the oldest:
// extraction, most of a view's cost, runs in parallel across views; the commit (cluster,
// transaction, memory) stays sequential and in stream order, as one EnrollView after another.
// Extractions still pass the registry's extraction gate.
class PreparedStream {
 public:
  struct View {
    v1::EnrollViewRequest request;
    absl::StatusOr<CrossingRegistry::PreparedEnrollment> prepared;
  };

  PreparedStream(CrossingRegistry* registry, size_t depth) : registry_(registry), depth_(depth) {}
  // Waits for the views still being prepared (their futures join on destruction).
  ~PreparedStream() = default;

  // The oldest view once prepared, after reading from `reader` until `depth` views are pending
  // or the client's stream ended (each read touches `watch`); nullopt once nothing is left.
  template <typename Reader>
  std::optional<View> Next(Reader* reader, IdleStreamReaper::Watch& watch) {
    v1::EnrollViewRequest request;
    while (reading_ && pending_.size() < depth_ && (reading_ = reader->Read(&request))) {
      watch.Touch();
      Push(std::move(request));
    }
    if (pending_.empty()) return std::nullopt;
    Pending front = std::move(pending_.front());
    pending_.pop_front();
    absl::StatusOr<CrossingRegistry::PreparedEnrollment> prepared = front.prepared.get();
    // Prepared: nothing reads the request any more, so it moves out rather than copying the image.
    return View{std::move(*front.request), std::move(prepared)};
  }

 private:
  struct Pending {
    std::shared_ptr<v1::EnrollViewRequest> request;
    std::future<absl::StatusOr<CrossingRegistry::PreparedEnrollment>> prepared;
  };

  void Push(v1::EnrollViewRequest request) {
    auto shared = std::make_shared<v1::EnrollViewRequest>(std::move(request));
    pending_.push_back({shared, std::async(std::launch::async, [registry = registry_, shared] {
                          return registry->PrepareEnrollment(*shared);
                        })});
  }

  CrossingRegistry* registry_;
  size_t depth_;
  bool reading_ = true;
  std::deque<Pending> pending_;
};

// Views prepared ahead of the commit: one per hardware thread keeps the cores busy extracting
// while the handler's thread commits.
size_t PrepareAhead() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace

CrossingServiceImpl::CrossingServiceImpl(CrossingRegistry* registry, Authenticator* auth,
                                         StreamLimiter* streams, IdleStreamReaper* idle)
    : registry_(registry), auth_(auth), streams_(streams), idle_(idle) {
  MarkMethodStreamed(MethodIndex<v1::CrossingService>("BulkEnroll"),
                     ParsedHandler(this, &CrossingServiceImpl::ServeBulkEnroll));
  MarkMethodStreamed(MethodIndex<v1::CrossingService>("StreamEnroll"),
                     ParsedHandler(this, &CrossingServiceImpl::ServeStreamEnroll));
  MarkMethodStreamed(MethodIndex<v1::CrossingService>("StreamRecognize"),
                     ParsedHandler(this, &CrossingServiceImpl::ServeStreamRecognize));
}

absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> CrossingServiceImpl::AuthorizeStream(
    const grpc::ServerContext& context, Action action) {
  absl::StatusOr<Caller> caller = auth_->Authorize(context, action);
  if (!caller.ok()) return caller.status();
  // With auth off there is no robot identity to count streams against.
  if (caller->auth_off) return std::unique_ptr<StreamLimiter::Lease>();
  return streams_->Acquire(caller->robot_id);
}

grpc::Status CrossingServiceImpl::CreateDatabase(grpc::ServerContext* context,
                                                 const v1::CreateDatabaseRequest* request,
                                                 v1::CrossingDatabase* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditCrossings, response,
                         [&](const Caller&) { return registry_->CreateDatabase(*request); });
}

grpc::Status CrossingServiceImpl::ListDatabases(grpc::ServerContext* context,
                                                const v1::ListDatabasesRequest*,
                                                v1::ListDatabasesResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kReadCrossings, response,
                         [&](const Caller&) { return registry_->ListDatabases(); });
}

grpc::Status CrossingServiceImpl::DeleteDatabase(grpc::ServerContext* context,
                                                 const v1::DeleteDatabaseRequest* request,
                                                 v1::DeleteDatabaseResponse*) {
  absl::StatusOr<Caller> caller = auth_->Authorize(*context, Action::kDeleteDatabase);
  if (!caller.ok()) return ToGrpcStatus(caller.status());
  return ToGrpcStatus(registry_->DeleteDatabase(request->name()));
}

grpc::Status CrossingServiceImpl::GetDatabaseStats(grpc::ServerContext* context,
                                                   const v1::GetDatabaseStatsRequest* request,
                                                   v1::DatabaseStats* response) {
  return ReplyAuthorized(*auth_, *context, Action::kReadCrossings, response,
                         [&](const Caller&) { return registry_->GetStats(request->name()); });
}

grpc::Status CrossingServiceImpl::AddCrossing(grpc::ServerContext* context,
                                              const v1::AddCrossingRequest* request,
                                              v1::Crossing* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditCrossings, response,
                         [&](const Caller&) { return registry_->AddCrossing(*request); });
}

grpc::Status CrossingServiceImpl::ListCrossings(grpc::ServerContext* context,
                                                const v1::ListCrossingsRequest* request,
                                                v1::ListCrossingsResponse* response) {
  return ReplyAuthorized(
      *auth_, *context, Action::kReadCrossings, response,
      [&](const Caller&) { return registry_->ListCrossings(request->database()); });
}

grpc::Status CrossingServiceImpl::DeleteCrossing(grpc::ServerContext* context,
                                                 const v1::DeleteCrossingRequest* request,
                                                 v1::DeleteCrossingResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditCrossings, response,
                         [&](const Caller&) { return registry_->DeleteCrossing(*request); });
}

grpc::Status CrossingServiceImpl::EnrollView(grpc::ServerContext* context,
                                             const v1::EnrollViewRequest* request,
                                             v1::EnrollViewResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditCrossings, response,
                         [&](const Caller&) { return registry_->EnrollView(*request); });
}

grpc::Status CrossingServiceImpl::ServeBulkEnroll(grpc::ServerContext* context,
                                                  BulkEnrollStream* stream) {
  // A client stream answered once: the response goes out only with an OK end (a stream that
  // ended at an unparsable message ends with its INVALID_ARGUMENT, ParsedHandler).
  v1::BulkEnrollResponse response;
  grpc::Status status = BulkEnrollInto(context, stream, &response);
  if (status.ok() && !stream->unparsed()) stream->Write(response);
  return status;
}

grpc::Status CrossingServiceImpl::BulkEnrollInto(grpc::ServerContext* context,
                                                 BulkEnrollStream* reader,
                                                 v1::BulkEnrollResponse* response) {
  absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> lease =
      AuthorizeStream(*context, Action::kEditCrossings);
  if (!lease.ok()) return ToGrpcStatus(lease.status());
  const auto watch = idle_->WatchStream(context, IdleStreamReaper::AtShutdown::kLetFinish,
                                        auth_->Revalidation(*context));
  PreparedStream stream(registry_, PrepareAhead());
  for (int index = 0;; ++index) {
    std::optional<PreparedStream::View> next = stream.Next(reader, *watch);
    if (!next) break;
    if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled");
    PreparedStream::View& view = *next;
    bool created = false;
    absl::StatusOr<v1::EnrollViewResponse> answer =
        EnrollStreamedView(view.request, std::move(view.prepared), &created);
    response->set_crossings_created(response->crossings_created() + (created ? 1 : 0));
    if (!answer.ok()) return EndEnrollStream(answer.status(), view.request, index, response->views());
    switch (answer->outcome()) {
      case v1::ENROLL_OUTCOME_INVALID: {
        v1::SkippedView* skipped = response->add_skipped();
        // The client's own values, to match the view by, but bounded: a view is often skipped
        // for an oversized field, which must not travel back whole (issue 35).
        skipped->set_crossing(BoundClientText(view.request.crossing(), kMaxEchoedChars));
        if (std::isfinite(view.request.heading_deg())) {
          skipped->set_heading_deg(view.request.heading_deg());
        }
        skipped->set_position(BoundClientText(view.request.position(), kMaxEchoedChars));
        skipped->set_index(index);
        skipped->set_reason(answer->error_message());
        break;
      }
      case v1::ENROLL_OUTCOME_DUPLICATE:
        response->set_duplicates(response->duplicates() + 1);
        break;
      default:
        response->set_views(response->views() + 1);
        response->set_clusters_created(response->clusters_created() +
                                       (answer->new_cluster() ? 1 : 0));
        response->set_keypoints(response->keypoints() + answer->keypoints());
        response->set_views_replaced(response->views_replaced() +
                                     answer->replaced_view_ids_size());
        break;
    }
  }
  return grpc::Status::OK;
}

grpc::Status CrossingServiceImpl::ServeStreamEnroll(grpc::ServerContext* context,
                                                    EnrollStream* stream) {
  absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> lease =
      AuthorizeStream(*context, Action::kEditCrossings);
  if (!lease.ok()) return ToGrpcStatus(lease.status());
  const auto watch = idle_->WatchStream(context, IdleStreamReaper::AtShutdown::kLetFinish,
                                        auth_->Revalidation(*context));
  PreparedStream pending(registry_, PrepareAhead());
  int stored = 0;
  for (int index = 0;; ++index) {
    // Each answer is written once its view is committed; the client may send ahead of the
    // answers (it need not wait for one before sending the next view).
    std::optional<PreparedStream::View> next = pending.Next(stream, *watch);
    if (!next) break;
    if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled");
    PreparedStream::View& view = *next;
    absl::StatusOr<v1::EnrollViewResponse> answer =
        EnrollStreamedView(view.request, std::move(view.prepared), nullptr);
    if (!answer.ok()) return EndEnrollStream(answer.status(), view.request, index, stored);
    if (answer->outcome() == v1::ENROLL_OUTCOME_STORED) ++stored;
    answer->set_index(index);
    if (!stream->Write(*answer)) break;  // the client went away; its views so far are stored
  }
  return grpc::Status::OK;
}

absl::StatusOr<v1::EnrollViewResponse> CrossingServiceImpl::EnrollStreamedView(
    const v1::EnrollViewRequest& request,
    absl::StatusOr<CrossingRegistry::PreparedEnrollment> prepared, bool* crossing_created) {
  const auto enroll = [&]() -> absl::StatusOr<v1::EnrollViewResponse> {
    if (prepared.ok()) {
      return registry_->CommitEnrollment(request, std::move(*prepared), crossing_created);
    }
    if (crossing_created != nullptr) *crossing_created = false;
    // Prepared before the views ahead of it committed, one of which may create the crossing it
    // names: enrolled again now, in stream order.
    if (prepared.status().code() == absl::StatusCode::kNotFound) {
      return registry_->EnrollView(request, crossing_created);
    }
    return prepared.status();
  };
  absl::StatusOr<v1::EnrollViewResponse> enrolled = enroll();
  if (enrolled.ok() || !request.skip_invalid() ||
      enrolled.status().code() != absl::StatusCode::kInvalidArgument) {
    return enrolled;
  }
  v1::EnrollViewResponse invalid;
  invalid.set_outcome(v1::ENROLL_OUTCOME_INVALID);
  invalid.set_crossing(BoundClientText(request.crossing(), kMaxEchoedChars));
  // Echoed only when finite: no NaN or inf leaves the server.
  if (std::isfinite(request.heading_deg())) invalid.set_heading_deg(request.heading_deg());
  invalid.set_position(BoundClientText(request.position(), kMaxEchoedChars));
  invalid.set_error_code(static_cast<int32_t>(enrolled.status().code()));
  invalid.set_error_message(BoundedStatusMessage(enrolled.status().message()));
  return invalid;
}

grpc::Status CrossingServiceImpl::EndEnrollStream(const absl::Status& error,
                                                  const v1::EnrollViewRequest& request, int index,
                                                  int stored) {
  // Views before this one are committed; say which one failed and how many made it.
  return ToGrpcStatus(absl::Status(
      error.code(), absl::StrCat("view ", index + 1, " [", stored,
                                 " views before it were stored] (crossing ",
                                 QuoteClientText(request.crossing()), ", heading ",
                                 request.heading_deg(), "): ", error.message())));
}

grpc::Status CrossingServiceImpl::RebuildClusters(grpc::ServerContext* context,
                                                  const v1::RebuildClustersRequest* request,
                                                  v1::RebuildClustersResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kEditCrossings, response,
                         [&](const Caller&) { return registry_->RebuildClusters(*request); });
}

grpc::Status CrossingServiceImpl::RecognizeCrossing(grpc::ServerContext* context,
                                                    const v1::RecognizeRequest* request,
                                                    v1::RecognizeResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kRecognize, response,
                         [&](const Caller&) { return registry_->Recognize(*request); });
}

grpc::Status CrossingServiceImpl::ServeStreamRecognize(grpc::ServerContext* context,
                                                       RecognizeStream* stream) {
  absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> lease =
      AuthorizeStream(*context, Action::kRecognize);
  if (!lease.ok()) return ToGrpcStatus(lease.status());
  const auto watch =
      idle_->WatchStream(context, IdleStreamReaper::AtShutdown::kEnd, auth_->Revalidation(*context));
  v1::RecognizeRequest request;
  int64_t frame = 0;
  StreamEvidence evidence;  // retrieval mode: the belief over the stream's frames
  while (stream->Read(&request)) {
    watch->Touch();
    if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled");
    crossing::RecognitionOptions effective;
    absl::StatusOr<v1::RecognizeResponse> result = registry_->Recognize(request, &effective);
    v1::RecognizeResponse response;
    if (result.ok()) {
      response = std::move(*result);
      evidence.Apply(effective, &response);
    } else if (result.status().code() == absl::StatusCode::kNotFound ||
               result.status().code() == absl::StatusCode::kFailedPrecondition) {
      // No frame can succeed against a missing or empty database: end the stream.
      return ToGrpcStatus(result.status());
    } else {
      // A bad frame (corrupt image, bad parameter) is reported and the robot keeps streaming.
      response.set_error_code(static_cast<int32_t>(result.status().code()));
      response.set_error_message(BoundedStatusMessage(result.status().message()));
      response.set_reason(absl::StrCat("frame rejected: ", response.error_message()));
      if (std::isfinite(request.image().stamp())) response.set_stamp(request.image().stamp());
    }
    response.set_frame_index(frame++);
    if (!stream->Write(response)) break;  // the client went away
  }
  return grpc::Status::OK;
}

}  // namespace waymark::service
