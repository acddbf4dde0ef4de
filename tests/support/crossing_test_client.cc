#include "tests/support/crossing_test_client.h"

#include <chrono>

#include "tests/support/synthetic_scene.h"

namespace waymark::testing {

CrossingTestClient::CrossingTestClient(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetMaxSendMessageSize(256 << 20);
  args.SetMaxReceiveMessageSize(256 << 20);
  channel_ = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
  stub_ = v1::CrossingService::NewStub(channel_);
}

std::unique_ptr<grpc::ClientContext> Ctx(int seconds) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return ctx;
}

v1::EnrollViewRequest EnrollRequest(const std::string& database, int crossing, double heading,
                                    const cv::Mat& panorama) {
  v1::EnrollViewRequest r;
  r.set_database(database);
  r.set_crossing("crossing-" + std::to_string(crossing));
  r.set_heading_deg(heading);
  r.set_create_crossing(true);
  const bool large = heading >= 180;
  const cv::Mat view = CropView(panorama, heading, 60, large ? 640 : 320, large ? 480 : 240);
  r.mutable_image()->set_data(static_cast<int>(heading) % 60 == 0 ? EncodePng(view)
                                                                  : EncodeJpeg(view));
  return r;
}

v1::RecognizeRequest RecognizeRequest(const std::string& database, const cv::Mat& image) {
  v1::RecognizeRequest r;
  r.set_database(database);
  r.mutable_image()->set_data(EncodeJpeg(image));
  return r;
}

}  // namespace waymark::testing
