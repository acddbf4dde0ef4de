#include "client/robot/crossing_watch.h"

#include <fmt/format.h>

#include "client/common/steady_clock.h"

namespace waymark::cli {

std::string DescribeRecognition(const v1::RecognizeResponse& response) {
  if (!response.recognized()) {
    return fmt::format("not recognized ({})",
                       response.reason().empty() ? "no qualifying view" : response.reason());
  }
  return fmt::format("{} (heading {:.0f} deg, Des {:.2f})", response.crossing(),
                     response.heading_deg(), response.decision());
}

CrossingWatch::CrossingWatch(client::CrossingClient& client,
                             std::unique_ptr<client::CameraSource> camera, std::string database,
                             double period_s, EventCallback on_event)
    : client_(client),
      camera_(std::move(camera)),
      database_(std::move(database)),
      period_s_(period_s),
      on_event_(std::move(on_event)) {
  thread_ = std::thread([this] { Loop(); });
}

CrossingWatch::~CrossingWatch() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void CrossingWatch::Request() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requested_ = true;
  }
  changed_.notify_all();
}

CrossingWatch::Result CrossingWatch::last() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_;
}

void CrossingWatch::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!quit_) {
    auto woken = [this] { return quit_ || requested_; };
    if (period_s_ > 0) {
      changed_.wait_for(lock, std::chrono::duration<double>(period_s_), woken);
    } else {
      changed_.wait(lock, woken);
    }
    if (quit_) break;
    requested_ = false;
    lock.unlock();
    RecognizeOnce();
    lock.lock();
  }
}

void CrossingWatch::RecognizeOnce() {
  std::string summary;
  bool ok = false, recognized = false;
  absl::StatusOr<std::string> frame = camera_->Next();
  if (!frame.ok()) {
    summary = fmt::format("camera: {}", frame.status().ToString());
  } else {
    v1::RecognizeRequest request;
    request.set_database(database_);
    request.mutable_image()->set_data(*std::move(frame));
    auto response = client_.RecognizeCrossing(request);
    if (!response.ok()) {
      summary = fmt::format("recognition failed: {}",
                            response.status().ToString(absl::StatusToStringMode::kWithNoExtraData));
    } else {
      ok = true;
      recognized = response->recognized();
      summary = DescribeRecognition(*response);
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++last_.attempts;
    if (!ok) ++last_.failures;
    last_.summary = summary;
    last_.recognized = recognized;
    last_.wall_time = adapters::SteadySeconds();
  }
  if (on_event_) on_event_(fmt::format("crossing: {}", summary));
}

}  // namespace waymark::cli
