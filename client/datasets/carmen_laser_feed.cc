#include "client/datasets/carmen_laser_feed.h"

#include <algorithm>
#include <utility>

namespace waymark::adapters {

CarmenLaserFeed::CarmenLaserFeed(std::unique_ptr<CarmenLogReader> reader, LaserFeedOptions options)
    : reader_(std::move(reader)), options_(options) {}

bool CarmenLaserFeed::Later(const CarmenRecord& a, const CarmenRecord& b) {
  return a.laser.stamp > b.laser.stamp || (a.laser.stamp == b.laser.stamp && a.line > b.line);
}

namespace {

void TakePosesOf(const CarmenLaser& from, CarmenLaser* to) {
  to->odom_pose = from.odom_pose;
  to->laser_pose = from.laser_pose;
}

}  // namespace

absl::StatusOr<bool> CarmenLaserFeed::NextLaserLine(CarmenRecord* record) {
  const int lag = options_.odometry_lag_scans;
  const auto read = [&](CarmenRecord* out) -> absl::StatusOr<bool> {
    while (true) {
      absl::StatusOr<bool> more = reader_->Next(out);
      if (!more.ok() || !*more) return more;
      if (out->type == CarmenRecord::Type::kOdometry) {
        ++odometry_lines_;
        continue;
      }
      ++laser_lines_;
      return true;
    }
  };
  if (lag <= 0) {
    absl::StatusOr<bool> more = read(record);
    if (!more.ok() || !*more || lag == 0) return more;
    // This line's poses are kept for the line -lag later; it takes the oldest kept (the first
    // line's while fewer than -lag lines came before it).
    lag_window_.push_back(*record);
    if (static_cast<int>(lag_window_.size()) > -lag + 1) lag_window_.pop_front();
    TakePosesOf(lag_window_.front().laser, &record->laser);
    return true;
  }
  // Read ahead until the line lag lines after the oldest waiting one is in (or the log ended).
  while (!lines_done_ && static_cast<int>(lag_window_.size()) <= lag) {
    CarmenRecord next;
    absl::StatusOr<bool> more = read(&next);
    if (!more.ok()) return more.status();
    if (!*more) {
      lines_done_ = true;
      break;
    }
    lag_window_.push_back(std::move(next));
  }
  if (lag_window_.empty()) return false;
  *record = std::move(lag_window_.front());
  lag_window_.pop_front();
  if (!lag_window_.empty()) {
    TakePosesOf(lag_window_[std::min<size_t>(lag - 1, lag_window_.size() - 1)].laser,
                &record->laser);
  }
  return true;
}

absl::StatusOr<bool> CarmenLaserFeed::NextRestamped(CarmenRecord* record) {
  absl::StatusOr<bool> more = NextLaserLine(record);
  if (!more.ok() || !*more) return more;
  record->laser.stamp = static_cast<double>(restamped_lines_++) / options_.restamp_rate_hz;
  return true;
}

absl::StatusOr<bool> CarmenLaserFeed::Next(CarmenRecord* record) {
  if (restamped()) return NextRestamped(record);
  while (true) {
    while (!eof_ && pending_.size() <= kReorderWindow) {
      CarmenRecord next;
      absl::StatusOr<bool> more = NextLaserLine(&next);
      if (!more.ok()) return more.status();
      if (!*more) {
        eof_ = true;
        break;
      }
      if (have_read_ && next.laser.stamp < max_read_) ++reordered_;
      max_read_ = have_read_ ? std::max(max_read_, next.laser.stamp) : next.laser.stamp;
      have_read_ = true;
      pending_.push_back(std::move(next));
      std::push_heap(pending_.begin(), pending_.end(), Later);
    }
    if (pending_.empty()) return false;
    std::pop_heap(pending_.begin(), pending_.end(), Later);
    *record = std::move(pending_.back());
    pending_.pop_back();
    if (have_last_ && !(record->laser.stamp > last_stamp_)) {
      if (record->laser.stamp == last_stamp_) {
        ++skipped_repeated_;
        last_repeated_stamp_ = last_stamp_;
      } else {
        ++skipped_earlier_;
      }
      continue;
    }
    have_last_ = true;
    last_stamp_ = record->laser.stamp;
    return true;
  }
}

}  // namespace waymark::adapters
