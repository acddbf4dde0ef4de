#ifndef WAYMARK_CLIENT_DATASETS_CARMEN_LOG_H_
#define WAYMARK_CLIENT_DATASETS_CARMEN_LOG_H_

// Streaming reader for CARMEN text logs (the Radish / Freiburg SLAM-evaluation format): plain,
// gzip or bzip2, detected by the file's magic bytes, never by its name. One line at a time, so a
// log of any size is read in constant memory.
//
// Records, in file order:
//   ODOM x y theta tv rv accel ts host ts
//   FLASER n r_1..r_n x y theta odom_x odom_y odom_theta ts host ts
//   ROBOTLASER1 type start fov res max_range accuracy remission_mode n r_1..r_n
//               n_rem [rem..] laser_x laser_y laser_theta robot_x robot_y robot_theta
//               tv rv forward_safety side_safety turn_axis ts host ts
// `ts` is the ipc_timestamp, the stamp the .relations files use. PARAM, NEFF, SYNC, other message
// types, blank lines and `#` comments are ignored.
//
// FLASER carries no beam geometry. CARMEN's convention, used here: the first beam points at -90 deg
// (to the right), and the increment is 1 deg for n = 180 or 181, 0.5 deg for n = 360 or 361, and
// pi / n otherwise (a 180-deg field of view split evenly). FLASER has no max-range field, so its
// no_return_range is 0 (unknown); the logs' no-return value (50 m, ~81.9 m) lies far beyond the
// SLAM range filter (6 m) and is dropped there. ROBOTLASER1 carries its own start angle,
// resolution and count, and its max_range is the no-return value.

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::adapters {

struct CarmenPose {
  double x = 0;
  double y = 0;
  double theta = 0;
};

struct CarmenOdometry {
  double stamp = 0;  // ipc_timestamp (s)
  CarmenPose pose;   // cumulative wheel odometry (m, m, rad)
  double tv = 0;     // m/s
  double rv = 0;     // rad/s
};

struct CarmenLaser {
  enum class Kind { kFlaser, kRobotLaser1 };
  Kind kind = Kind::kFlaser;
  double stamp = 0;            // ipc_timestamp (s)
  double angle_min = 0;        // bearing of the first beam in the laser frame (rad)
  double angle_increment = 0;  // rad
  double no_return_range = 0;  // readings at or above are no-returns; 0 = unknown (FLASER)
  std::vector<float> ranges;   // m, one per beam
  CarmenPose laser_pose;       // the laser's pose as logged (FLASER x y theta, ROBOTLASER1 laser_*)
  CarmenPose odom_pose;        // the robot's odometry pose (FLASER odom_*, ROBOTLASER1 robot_*)
};

struct CarmenRecord {
  enum class Type { kOdometry, kLaser };
  Type type = Type::kOdometry;
  int64_t line = 0;  // 1-based line number in the (decompressed) log
  CarmenOdometry odometry;  // when type == kOdometry
  CarmenLaser laser;        // when type == kLaser
};

// FLASER's beam increment for n beams (see the file comment).
double FlaserAngleIncrement(int beam_count);
inline constexpr double kFlaserAngleMin = -1.5707963267948966;  // -90 deg

// Parses one log line. Returns true and fills `record` for ODOM / FLASER / ROBOTLASER1, false for
// lines that carry no record (comments, PARAM, NEFF, unknown messages), INVALID_ARGUMENT naming
// the line number and the problem for a malformed record.
absl::StatusOr<bool> ParseCarmenLine(const std::string& line, int64_t line_number,
                                     CarmenRecord* record);

class ByteSource;

class CarmenLogReader {
 public:
  enum class Compression { kPlain, kGzip, kBzip2 };

  struct Options {
    // true: malformed lines are counted (malformed_lines(), first_errors()) and skipped;
    // false: Next() returns the error for the line (and reading can go on after it).
    bool skip_malformed = true;
  };

  // NOT_FOUND if the file does not exist, PERMISSION_DENIED if unreadable.
  static absl::StatusOr<std::unique_ptr<CarmenLogReader>> Open(const std::string& path);
  static absl::StatusOr<std::unique_ptr<CarmenLogReader>> Open(const std::string& path,
                                                               Options options);
  ~CarmenLogReader();
  CarmenLogReader(const CarmenLogReader&) = delete;
  CarmenLogReader& operator=(const CarmenLogReader&) = delete;

  // The next record: true = `record` filled, false = end of log. Errors: INVALID_ARGUMENT for a
  // malformed line (only without skip_malformed), DATA_LOSS for a corrupt or truncated
  // compressed stream (reading cannot continue).
  absl::StatusOr<bool> Next(CarmenRecord* record);

  Compression compression() const { return compression_; }
  int64_t lines_read() const { return line_number_; }
  int64_t malformed_lines() const { return malformed_; }
  // The messages of the first few malformed lines ("line 12: FLASER: ...").
  const std::vector<std::string>& first_errors() const { return first_errors_; }
  // Compressed bytes consumed so far and the file size, for progress bars.
  int64_t bytes_consumed() const;
  int64_t file_size() const { return file_size_; }

 private:
  CarmenLogReader() = default;
  // Reads one line (without the newline) into line_; false at end of input.
  absl::StatusOr<bool> ReadLine();

  static constexpr size_t kMaxErrorsKept = 10;

  Options options_;
  Compression compression_ = Compression::kPlain;
  std::unique_ptr<ByteSource> source_;
  std::string buffer_;
  size_t buffer_pos_ = 0;
  bool eof_ = false;
  std::string line_;
  int64_t line_number_ = 0;
  int64_t malformed_ = 0;
  int64_t file_size_ = 0;
  std::vector<std::string> first_errors_;
};

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_DATASETS_CARMEN_LOG_H_
