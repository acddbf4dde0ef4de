#ifndef WAYMARK_CLIENT_SESSIONS_SIM_EXPLORE_LOOP_H_
#define WAYMARK_CLIENT_SESSIONS_SIM_EXPLORE_LOOP_H_

// The parts of the simulated exploration loop that one robot (sim_explore.h) and several robots
// in one map (sim_team_explore.h) share: the simulator's options from the run's, the session
// request, waiting for a scan's answer, and the sensor side of one robot's stream.

#include <fmt/format.h>

#include <condition_variable>
#include <cstdint>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <ostream>
#include <vector>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/lib/slam_client.h"
#include "client/robot/laser_session.h"
#include "client/sessions/sim_explore.h"
#include "client/sim/sim_robot.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// The simulator as the run asks for it: seed, beam mode, the base's limits (the planner's, when
// --exploration sets them) and the odometry error scaled by options.odometry_error.
adapters::SimOptions SimOptionsFor(const ExploreOptions& options);

// The simulator's and the API's poses as the run's.
inline Pose2 ToPose2(const adapters::BasePose& p) { return {p.x, p.y, p.theta}; }
inline Pose2 ToPose2(const v1::Pose2D& p) { return {p.x(), p.y(), p.theta()}; }

// What a scan's answer says besides the pose (covariance trace, segments, closures, the
// suggestion and exploration's progress), into `record`.
void RecordAnswer(const v1::SlamUpdate& update, ScanRecord* record);

// The session of a run (robot "sim" unless `robot_id` says otherwise).
v1::CreateSessionRequest SessionRequest(const adapters::Simulation& sim,
                                        const adapters::World& world,
                                        const ExploreOptions& options,
                                        const std::string& robot_id = "sim");

// Turns the stream's asynchronous answers into "wait for the answer to the scan just sent". Any
// rejection (odometry ones arrive unprompted) is kept and ends the run at the next wait.
class AnswerWaiter {
 public:
  void OnUpdate(const v1::SlamUpdate& update) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (update.has_rejection()) {
        if (!rejection_) rejection_ = update;
      } else {
        latest_ = update;
        ++answers_;
      }
    }
    changed_.notify_all();
  }

  // Waits for answer number `n` (1-based) or a rejection.
  absl::StatusOr<v1::SlamUpdate> Wait(uint64_t n, absl::Duration timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    const bool ready = changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                                         [&] { return rejection_ || answers_ >= n; });
    if (absl::Status s = RejectionLocked(); !s.ok()) return s;
    if (!ready) {
      return absl::DeadlineExceededError(
          fmt::format("no answer to scan {} within {}", n, absl::FormatDuration(timeout)));
    }
    return latest_;
  }

  absl::Status Rejection() {
    std::lock_guard<std::mutex> lock(mutex_);
    return RejectionLocked();
  }

 private:
  absl::Status RejectionLocked() const {
    if (!rejection_) return absl::OkStatus();
    return absl::Status(static_cast<absl::StatusCode>(rejection_->rejection().code()),
                        fmt::format("message {} rejected: {}", rejection_->sequence(),
                                    rejection_->rejection().message()));
  }

  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<v1::SlamUpdate> rejection_;
  v1::SlamUpdate latest_;
  uint64_t answers_ = 0;
};

// Robot `k`'s (from 1) recording, ExploreOptions::record_dir/robot<k>.clf; null when the run
// records nothing. PERMISSION_DENIED when it cannot be written.
absl::StatusOr<std::unique_ptr<std::ofstream>> OpenRecording(const ExploreOptions& options, int k);

// The sensor side of the loop: stamps and messages from the simulation onto the stream.
class SimRobotLink {
 public:
  SimRobotLink(adapters::Simulation& sim, client::SensorStream& stream, AnswerWaiter& waiter,
               absl::Duration timeout)
      : sim_(sim), stream_(stream), waiter_(waiter), timeout_(timeout) {}

  // Also writes what it sends to `log` (not owned; null: nothing) as a CARMEN log (ODOM and
  // FLASER lines, the laser's pose the odometry's composed with its mount): the same robot data
  // replayed later with `waymark slam replay`, whatever the answers it gets then.
  void RecordTo(std::ostream* log) { log_ = log; }

  absl::Status SendOdometry() {
    v1::Odometry odometry;
    odometry.set_stamp(sim_.now());
    *odometry.mutable_pose() = ToProto(sim_.odometry_pose());
    if (log_ != nullptr) {
      const adapters::BasePose p = sim_.odometry_pose();
      *log_ << fmt::format("ODOM {:.6f} {:.6f} {:.6f} 0 0 0 {:.6f} sim {:.6f}\n", p.x, p.y,
                           p.theta, sim_.now(), sim_.now());
    }
    return stream_.SendOdometry(odometry);
  }

  // Scans at the current instant and waits for the SlamUpdate.
  absl::StatusOr<v1::SlamUpdate> ScanAndWait() {
    auto reading = sim_.laser().Read();
    if (!reading.ok()) return reading.status();
    v1::LaserScan scan;
    scan.set_stamp(sim_.now());
    scan.mutable_ranges()->Assign(reading->ranges.begin(), reading->ranges.end());
    if (log_ != nullptr) RecordScan(reading->ranges);
    if (absl::Status s = stream_.SendScan(scan); !s.ok()) return s;
    return waiter_.Wait(++scans_, timeout_);
  }

 private:
  adapters::Simulation& sim_;
  client::SensorStream& stream_;
  AnswerWaiter& waiter_;
  absl::Duration timeout_;
  uint64_t scans_ = 0;
  std::ostream* log_ = nullptr;

  void RecordScan(const std::vector<float>& ranges);
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_SIM_EXPLORE_LOOP_H_
