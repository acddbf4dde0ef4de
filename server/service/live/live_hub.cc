#include "server/service/live/live_hub.h"

#include <algorithm>
#include <iterator>
#include <utility>

namespace waymark::service::live {

void LiveHub::OnInput(const std::string& session_id, const v1::SensorData& data) {
  if (!watched_.load(std::memory_order_relaxed)) return;
  if (data.payload_case() != v1::SensorData::kScan) return;
  // Copied before the lock: the robot's thread holds the mutex only to move it in.
  const v1::LaserScan& in = data.scan();
  ScanSample scan;
  scan.sequence = data.sequence();
  scan.stamp = in.stamp();
  scan.angle_min = in.geometry().angle_min();
  scan.angle_increment = in.geometry().angle_increment();
  scan.no_return_range = in.geometry().no_return_range();
  scan.ranges.assign(in.ranges().begin(), in.ranges().end());
  std::lock_guard<std::mutex> lock(mu_);
  std::deque<ScanSample>& admitted = sessions_[session_id].admitted;
  admitted.push_back(std::move(scan));
  while (admitted.size() > scan_ring_) admitted.pop_front();
}

void LiveHub::OnUpdate(const std::string& session_id, const v1::SlamUpdate& update) {
  if (!watched_.load(std::memory_order_relaxed)) return;
  if (update.has_rejection() || update.has_stream_start()) return;
  v1::SlamUpdate copy = update;
  // What the live view never sends: the features' pixel positions and the planner's path.
  copy.mutable_visual()->clear_feature_xy();
  copy.mutable_visual()->clear_feature_labels();
  if (!update.has_visual()) copy.clear_visual();
  std::lock_guard<std::mutex> lock(mu_);
  Slots& slots = sessions_[session_id];
  // The scans are answered in order: those before this one will get no answer of their own.
  while (!slots.admitted.empty() && slots.admitted.front().sequence < update.sequence()) {
    slots.admitted.pop_front();
  }
  if (!slots.admitted.empty() && slots.admitted.front().sequence == update.sequence()) {
    slots.scan = std::move(slots.admitted.front());
    slots.admitted.pop_front();
  } else if (slots.scan.has_value() && slots.scan->sequence != update.sequence()) {
    slots.scan.reset();  // never draw a scan beside another scan's pose
  }
  slots.update = std::move(copy);
}

void LiveHub::OnRecognition(const std::string& database, const v1::RecognizeResponse& response) {
  if (!watched_.load(std::memory_order_relaxed)) return;
  Recognition recognition{database, response};
  recognition.response.clear_candidates();
  std::lock_guard<std::mutex> lock(mu_);
  recognitions_.push_back(std::move(recognition));
  while (recognitions_.size() > max_recognitions_) {
    recognitions_.pop_front();
    ++recognitions_dropped_;
  }
}

LiveHub::Latest LiveHub::Take(const std::string& session_id) {
  Latest out;
  std::lock_guard<std::mutex> lock(mu_);
  auto found = sessions_.find(session_id);
  if (found == sessions_.end()) return out;
  out.update = std::move(found->second.update);
  found->second.update.reset();
  if (out.update.has_value() && found->second.scan.has_value() &&
      found->second.scan->sequence == out.update->sequence()) {
    out.scan = std::move(found->second.scan);
    found->second.scan.reset();
  }
  return out;
}

std::vector<std::string> LiveHub::SessionsWithNews() {
  std::vector<std::string> out;
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, slots] : sessions_) {
    if (slots.update.has_value()) out.push_back(id);
  }
  return out;
}

std::vector<LiveHub::Recognition> LiveHub::TakeRecognitions() {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<Recognition> out(std::make_move_iterator(recognitions_.begin()),
                               std::make_move_iterator(recognitions_.end()));
  recognitions_.clear();
  return out;
}

void LiveHub::Forget(const std::string& session_id) {
  std::lock_guard<std::mutex> lock(mu_);
  sessions_.erase(session_id);
}

void LiveHub::Retain(const std::vector<std::string>& open_sessions) {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    if (std::find(open_sessions.begin(), open_sessions.end(), it->first) == open_sessions.end()) {
      it = sessions_.erase(it);
    } else {
      ++it;
    }
  }
}

size_t LiveHub::sessions() const {
  std::lock_guard<std::mutex> lock(mu_);
  return sessions_.size();
}

uint64_t LiveHub::recognitions_dropped() const {
  std::lock_guard<std::mutex> lock(mu_);
  return recognitions_dropped_;
}

}  // namespace waymark::service::live
