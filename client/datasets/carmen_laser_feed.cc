#include "client/datasets/carmen_laser_feed.h"

#include <algorithm>
#include <utility>

namespace waymark::adapters {

CarmenLaserFeed::CarmenLaserFeed(std::unique_ptr<CarmenLogReader> reader, LaserFeedOptions options)
    : reader_(std::move(reader)), options_(options) {}

bool CarmenLaserFeed::Later(const CarmenRecord& a, const CarmenRecord& b) {
  return a.laser.stamp > b.laser.stamp || (a.laser.stamp == b.laser.stamp && a.line > b.line);
}

absl::StatusOr<bool> CarmenLaserFeed::NextRestamped(CarmenRecord* record) {
  while (true) {
    absl::StatusOr<bool> more = reader_->Next(record);
    if (!more.ok() || !*more) return more;
    if (record->type == CarmenRecord::Type::kOdometry) {
      ++odometry_lines_;
      continue;
    }
    record->laser.stamp = static_cast<double>(laser_lines_) / options_.restamp_rate_hz;
    ++laser_lines_;
    return true;
  }
}

absl::StatusOr<bool> CarmenLaserFeed::Next(CarmenRecord* record) {
  if (restamped()) return NextRestamped(record);
  while (true) {
    while (!eof_ && pending_.size() <= kReorderWindow) {
      CarmenRecord next;
      absl::StatusOr<bool> more = reader_->Next(&next);
      if (!more.ok()) return more.status();
      if (!*more) {
        eof_ = true;
        break;
      }
      if (next.type == CarmenRecord::Type::kOdometry) {
        ++odometry_lines_;
        continue;
      }
      ++laser_lines_;
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
