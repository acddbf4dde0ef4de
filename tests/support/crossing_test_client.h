#ifndef WAYMARK_TESTS_SUPPORT_CROSSING_TEST_CLIENT_H_
#define WAYMARK_TESTS_SUPPORT_CROSSING_TEST_CLIENT_H_

// What integration tests of the crossing service share: a raw stub on a plaintext channel (the
// test servers run with --insecure-dev on loopback), a context with a deadline, and requests built
// from generated panoramas (synthetic_scene.h).

#include <grpcpp/grpcpp.h>

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark::testing {

class CrossingTestClient {
 public:
  explicit CrossingTestClient(const std::string& address);
  v1::CrossingService::Stub* operator->() { return stub_.get(); }
  std::shared_ptr<grpc::Channel> channel() { return channel_; }

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::CrossingService::Stub> stub_;
};

// A context with a deadline, as every robot call should have.
std::unique_ptr<grpc::ClientContext> Ctx(int seconds = 60);

// Enrolls the view of `panorama` at `heading` as crossing "crossing-<crossing>" (created if
// needed). Alternates PNG and JPEG and gives views at headings >= 180 at twice the working size,
// so enrollment exercises both decoders and the resize.
v1::EnrollViewRequest EnrollRequest(const std::string& database, int crossing, double heading,
                                    const cv::Mat& panorama);

// Recognizes `image` (sent as JPEG) in `database`.
v1::RecognizeRequest RecognizeRequest(const std::string& database, const cv::Mat& image);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_CROSSING_TEST_CLIENT_H_
