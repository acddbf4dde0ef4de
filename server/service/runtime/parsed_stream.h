#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_PARSED_STREAM_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_PARSED_STREAM_H_

// Client streams whose messages this server parses itself. gRPC's synchronous reader reports a
// message it cannot parse exactly as it reports the end of the stream: a robot that sent 5 good
// frames, one corrupt message and 5 more got 5 answers and status OK, and could not tell that
// from a normal end. Here the handler reads raw bytes (the generated typed handler is replaced
// with MarkMethodStreamed, see ParsedHandler) and parses them, so an unparsable message ends the
// stream with INVALID_ARGUMENT naming its position, after every message before it was answered.
//
// Responses stay typed (only requests are raw), so the call interceptor and the client see the
// same messages as before.

#include <google/protobuf/descriptor.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/support/method_handler.h>

#include <cstdint>
#include <optional>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/service/runtime/folder.h"

namespace waymark::service {

template <class Response, class Request>
class ParsedStream {
 public:
  using Raw = grpc::ServerReaderWriter<Response, grpc::ByteBuffer>;
  explicit ParsedStream(Raw* raw) : raw_(raw) {}

  // The next message; false at the end of the stream, and at a message that does not parse
  // (unparsed() then says which; nothing more is read).
  bool Read(Request* request) {
    if (unparsed_) return false;
    grpc::ByteBuffer bytes;
    if (!raw_->Read(&bytes)) return false;
    ++messages_;
    const grpc::Status parsed = grpc::SerializationTraits<Request>::Deserialize(&bytes, request);
    if (!parsed.ok()) {
      unparsed_ = grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                               absl::StrCat("message ", messages_, " of the stream is not a ",
                                            Request::descriptor()->full_name(),
                                            " (it does not parse); the stream ends there, the ",
                                            messages_ - 1, " before it were taken"));
      return false;
    }
    return true;
  }
  bool Write(const Response& response) { return raw_->Write(response); }

  // Set once a message did not parse.
  const std::optional<grpc::Status>& unparsed() const { return unparsed_; }

 private:
  Raw* raw_;
  int64_t messages_ = 0;
  std::optional<grpc::Status> unparsed_;
};

// The position of `method` in `Service` (the generated service's method table follows the
// proto's order).
template <class Service>
int MethodIndex(const std::string& method) {
  const google::protobuf::ServiceDescriptor* service =
      google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
          Service::service_full_name());
  const google::protobuf::MethodDescriptor* found =
      service != nullptr ? service->FindMethodByName(method) : nullptr;
  return found != nullptr ? found->index() : -1;
}

// A handler for MarkMethodStreamed: runs `method` of `service` on a ParsedStream. A stream that
// ended at an unparsable message ends with that INVALID_ARGUMENT, unless the handler already
// ended it with an error of its own.
template <class Impl, class Response, class Request>
grpc::internal::MethodHandler* ParsedHandler(
    Impl* service,
    grpc::Status (Impl::*method)(grpc::ServerContext*, ParsedStream<Response, Request>*)) {
  return new grpc::internal::BidiStreamingHandler<Impl, grpc::ByteBuffer, Response>(
      [method](Impl* impl, grpc::ServerContext* context,
               grpc::ServerReaderWriter<Response, grpc::ByteBuffer>* raw) {
        ParsedStream<Response, Request> stream(raw);
        const grpc::Status status = (impl->*method)(context, &stream);
        if (status.ok() && stream.unparsed()) return *stream.unparsed();
        return status;
      },
      service);
}

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_PARSED_STREAM_H_
