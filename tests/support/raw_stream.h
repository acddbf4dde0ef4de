#ifndef WAYMARK_TESTS_SUPPORT_RAW_STREAM_H_
#define WAYMARK_TESTS_SUPPORT_RAW_STREAM_H_

// A client stream of raw bytes to any streaming method, for sending what a typed stub cannot:
// messages that do not parse. Answers are parsed as `Response`.

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/client_callback.h>
#include <grpcpp/support/sync_stream.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <google/protobuf/message.h>

namespace waymark::testing {

class RawStream {
 public:
  // `method`: "/package.Service/Method". The call is opened as a bidi stream (a client-streaming
  // method looks the same on the wire).
  RawStream(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
            int deadline_seconds = 60)
      : method_name_(method),
        method_(method_name_.c_str(), grpc::internal::RpcMethod::BIDI_STREAMING) {
    context_.set_deadline(std::chrono::system_clock::now() +
                          std::chrono::seconds(deadline_seconds));
    stream_.reset(grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::
                      Create(channel.get(), method_, &context_));
  }

  bool Write(const google::protobuf::Message& message) {
    return WriteBytes(message.SerializeAsString());
  }
  bool WriteBytes(const std::string& bytes) {
    grpc::Slice slice(bytes);
    grpc::ByteBuffer buffer(&slice, 1);
    return stream_->Write(buffer);
  }
  // Half-closes, reads every answer, and returns the call's status.
  template <class Response>
  grpc::Status Finish(std::vector<Response>* answers) {
    stream_->WritesDone();
    grpc::ByteBuffer buffer;
    while (stream_->Read(&buffer)) {
      Response answer;
      std::vector<grpc::Slice> slices;
      if (buffer.Dump(&slices).ok()) {
        std::string bytes;
        for (const grpc::Slice& s : slices) bytes.append(s.begin(), s.end());
        answer.ParseFromString(bytes);
      }
      answers->push_back(answer);
    }
    return stream_->Finish();
  }

 private:
  std::string method_name_;
  grpc::internal::RpcMethod method_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream_;
};

// Bytes that are no protobuf message: field 1, length-delimited, with a length varint that
// never ends.
inline std::string UnparsableMessage() { return std::string("\x0a\xff\xff\xff\xff\xff\xff", 7); }

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_RAW_STREAM_H_
