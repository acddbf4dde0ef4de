#ifndef WAYMARK_CLIENT_ROBOT_CROSSING_WATCH_H_
#define WAYMARK_CLIENT_ROBOT_CROSSING_WATCH_H_

// Crossing recognition from the robot's camera while it drives (`waymark robot --camera`): a
// thread grabs a frame every `period` (or when Request() asks), sends it to RecognizeCrossing and
// keeps the last answer for the status line. It never blocks the control loop; a failed frame or
// call is reported and the next period tries again.

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "client/devices/camera_source.h"
#include "client/lib/crossing_client.h"

namespace waymark::cli {

class CrossingWatch {
 public:
  struct Result {
    uint64_t attempts = 0;
    uint64_t failures = 0;
    std::string summary;  // "K3 (heading 92 deg, Des 0.81)", "not recognized: ...", the error
    bool recognized = false;
    double wall_time = 0;  // steady-clock seconds of the answer
  };
  using EventCallback = std::function<void(const std::string&)>;

  // `period_s` <= 0: only on Request().
  CrossingWatch(client::CrossingClient& client, std::unique_ptr<client::CameraSource> camera,
                std::string database, double period_s, EventCallback on_event = {});
  ~CrossingWatch();

  // Recognize at the next opportunity (a key press, SIGUSR1).
  void Request();
  Result last() const;

 private:
  void Loop();
  void RecognizeOnce();

  client::CrossingClient& client_;
  std::unique_ptr<client::CameraSource> camera_;
  const std::string database_;
  const double period_s_;
  EventCallback on_event_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool requested_ = false;
  bool quit_ = false;
  Result last_;
  std::thread thread_;
};

// The status-line text of one answer.
std::string DescribeRecognition(const v1::RecognizeResponse& response);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_CROSSING_WATCH_H_
