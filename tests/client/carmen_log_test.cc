// The CARMEN log reader on generated plain / gzip / bzip2 logs and on the first lines of the real
// ACES and Intel logs (skipped when ../shared is absent).
#include "client/datasets/carmen_log.h"

#include <bzlib.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/client/test_util.h"

namespace waymark::adapters {
namespace {

using testing::ScopedTempDir;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

std::string Flaser(int n, double stamp, double first_range = 1.0) {
  std::ostringstream line;
  line << "FLASER " << n;
  for (int i = 0; i < n; ++i) line << " " << (i == 0 ? first_range : 2.5);
  line << " 1.0 2.0 0.5 1.1 2.1 0.6 " << std::fixed << stamp << " nohost 0.5";
  return line.str();
}

std::string RobotLaser(int n, double stamp) {
  std::ostringstream line;
  line << "ROBOTLASER1 0 -1.570796 3.141593 0.017453 81.900000 0.010000 0 " << n;
  for (int i = 0; i < n; ++i) line << " " << 3.0 + 0.01 * i;
  line << " 0 0.22 0.1 0.05 0.2 0.1 0.05 0.3 0.01 0 0 0 " << std::fixed << stamp
       << " zoidberg2 -0.05";
  return line.str();
}

// A small log: a comment, PARAM, ODOM, FLASER 180, a malformed FLASER, ROBOTLASER1, FLASER 361,
// NEFF, a malformed ODOM.
std::string SampleLog() {
  std::ostringstream log;
  log << "# message_name [message contents] ipc_timestamp ipc_hostname logger_timestamp\n";
  log << "PARAM robot_frontlaser_offset 0.0 nohost 0\n";
  log << "ODOM 0.5 0.25 -0.1 0.2 0.01 0 100.000000 nohost 0.1\n";  // line 3
  log << Flaser(180, 100.5) << "\n";                                 // line 4
  log << "FLASER 180 1.0 2.0 nohost 0\n";                            // line 5: too short
  log << RobotLaser(181, 101.0) << "\n";                             // line 6
  log << "\n";                                                       // line 7
  log << Flaser(361, 101.5, 4.25) << "\n";                           // line 8
  log << "NEFF 23.5\n";                                              // line 9
  log << "ODOM 0.5 x -0.1 0.2 0.01 0 102.0 nohost 0.1\n";            // line 10: not a number
  log << "ODOM 0.6 0.3 -0.2 0.2 0.01 0 102.500000 nohost 0.1";        // line 11, no newline
  return log.str();
}

void WritePlain(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

void WriteGzip(const std::filesystem::path& path, const std::string& text) {
  gzFile gz = gzopen(path.c_str(), "wb");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, text.data(), static_cast<unsigned>(text.size())),
            static_cast<int>(text.size()));
  gzclose(gz);
}

// Two concatenated bzip2 streams when `split` (as pbzip2 writes), else one.
void WriteBzip2(const std::filesystem::path& path, const std::string& text, bool split) {
  FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  const size_t cut = split ? text.size() / 2 : text.size();
  for (const std::string& part : {text.substr(0, cut), text.substr(cut)}) {
    if (part.empty()) continue;
    int error = BZ_OK;
    BZFILE* bz = BZ2_bzWriteOpen(&error, file, 9, 0, 0);
    ASSERT_EQ(error, BZ_OK);
    BZ2_bzWrite(&error, bz, const_cast<char*>(part.data()), static_cast<int>(part.size()));
    ASSERT_EQ(error, BZ_OK);
    BZ2_bzWriteClose(&error, bz, 0, nullptr, nullptr);
  }
  std::fclose(file);
}

std::vector<CarmenRecord> ReadAllRecords(CarmenLogReader& reader) {
  std::vector<CarmenRecord> records;
  CarmenRecord record;
  while (true) {
    auto more = reader.Next(&record);
    EXPECT_TRUE(more.ok()) << more.status();
    if (!more.ok() || !*more) break;
    records.push_back(record);
  }
  return records;
}

void CheckSample(CarmenLogReader& reader) {
  const std::vector<CarmenRecord> records = ReadAllRecords(reader);
  ASSERT_EQ(records.size(), 5u);
  EXPECT_EQ(reader.malformed_lines(), 2);
  ASSERT_EQ(reader.first_errors().size(), 2u);
  EXPECT_EQ(reader.first_errors()[0], "line 5: FLASER: expected 191 fields, got 6");
  EXPECT_EQ(reader.first_errors()[1],
            "line 10: ODOM: field 3 (odom_y) is not a number: 'x'");
  EXPECT_EQ(reader.lines_read(), 11);

  // ODOM
  EXPECT_EQ(records[0].type, CarmenRecord::Type::kOdometry);
  EXPECT_EQ(records[0].line, 3);
  EXPECT_DOUBLE_EQ(records[0].odometry.stamp, 100.0);
  EXPECT_DOUBLE_EQ(records[0].odometry.pose.x, 0.5);
  EXPECT_DOUBLE_EQ(records[0].odometry.pose.theta, -0.1);
  EXPECT_DOUBLE_EQ(records[0].odometry.tv, 0.2);

  // FLASER 180: -90 deg, 1 deg steps, laser pose and odometry pose.
  const CarmenLaser& f180 = records[1].laser;
  EXPECT_EQ(records[1].type, CarmenRecord::Type::kLaser);
  EXPECT_EQ(records[1].line, 4);
  EXPECT_EQ(f180.kind, CarmenLaser::Kind::kFlaser);
  EXPECT_DOUBLE_EQ(f180.stamp, 100.5);
  ASSERT_EQ(f180.ranges.size(), 180u);
  EXPECT_FLOAT_EQ(f180.ranges[0], 1.0f);
  EXPECT_FLOAT_EQ(f180.ranges[179], 2.5f);
  EXPECT_NEAR(f180.angle_min, -90 * kDeg, 1e-12);
  EXPECT_NEAR(f180.angle_increment, 1 * kDeg, 1e-12);
  EXPECT_NEAR(f180.angle_min + 179 * f180.angle_increment, 89 * kDeg, 1e-9);
  EXPECT_EQ(f180.no_return_range, 0);
  EXPECT_DOUBLE_EQ(f180.laser_pose.x, 1.0);
  EXPECT_DOUBLE_EQ(f180.laser_pose.theta, 0.5);
  EXPECT_DOUBLE_EQ(f180.odom_pose.x, 1.1);
  EXPECT_DOUBLE_EQ(f180.odom_pose.y, 2.1);
  EXPECT_DOUBLE_EQ(f180.odom_pose.theta, 0.6);

  // ROBOTLASER1: its own geometry, max range as no-return, robot pose as odometry.
  const CarmenLaser& rl = records[2].laser;
  EXPECT_EQ(rl.kind, CarmenLaser::Kind::kRobotLaser1);
  EXPECT_EQ(records[2].line, 6);
  EXPECT_DOUBLE_EQ(rl.stamp, 101.0);
  ASSERT_EQ(rl.ranges.size(), 181u);
  EXPECT_FLOAT_EQ(rl.ranges[180], 4.8f);
  EXPECT_DOUBLE_EQ(rl.angle_min, -1.570796);
  EXPECT_DOUBLE_EQ(rl.angle_increment, 0.017453);
  EXPECT_DOUBLE_EQ(rl.no_return_range, 81.9);
  EXPECT_DOUBLE_EQ(rl.laser_pose.x, 0.22);
  EXPECT_DOUBLE_EQ(rl.laser_pose.y, 0.1);
  EXPECT_DOUBLE_EQ(rl.odom_pose.x, 0.2);
  EXPECT_DOUBLE_EQ(rl.odom_pose.theta, 0.05);

  // FLASER 361: -90 .. +90 deg in 0.5 deg steps.
  const CarmenLaser& f361 = records[3].laser;
  ASSERT_EQ(f361.ranges.size(), 361u);
  EXPECT_FLOAT_EQ(f361.ranges[0], 4.25f);
  EXPECT_NEAR(f361.angle_increment, 0.5 * kDeg, 1e-12);
  EXPECT_NEAR(f361.angle_min + 360 * f361.angle_increment, 90 * kDeg, 1e-9);

  // The last line has no newline.
  EXPECT_EQ(records[4].line, 11);
  EXPECT_DOUBLE_EQ(records[4].odometry.stamp, 102.5);
}

TEST(CarmenLog, FlaserGeometryConvention) {
  EXPECT_NEAR(FlaserAngleIncrement(180), kDeg, 1e-15);
  EXPECT_NEAR(FlaserAngleIncrement(181), kDeg, 1e-15);
  EXPECT_NEAR(FlaserAngleIncrement(360), 0.5 * kDeg, 1e-15);
  EXPECT_NEAR(FlaserAngleIncrement(361), 0.5 * kDeg, 1e-15);
  EXPECT_NEAR(FlaserAngleIncrement(720), 0.25 * kDeg, 1e-15);
}

TEST(CarmenLog, PlainGzipAndBzip2ReadTheSame) {
  ScopedTempDir dir;
  const std::string text = SampleLog();
  WritePlain(dir.path() / "plain.clf", text);
  WriteGzip(dir.path() / "log.gz", text);
  WriteBzip2(dir.path() / "log.bz2", text, false);
  WriteBzip2(dir.path() / "two-streams.bz2", text, true);
  // Detection is by content: a gzip file named .clf is still gzip.
  WriteGzip(dir.path() / "misnamed.clf", text);
  const std::pair<const char*, CarmenLogReader::Compression> cases[] = {
      {"plain.clf", CarmenLogReader::Compression::kPlain},
      {"log.gz", CarmenLogReader::Compression::kGzip},
      {"log.bz2", CarmenLogReader::Compression::kBzip2},
      {"two-streams.bz2", CarmenLogReader::Compression::kBzip2},
      {"misnamed.clf", CarmenLogReader::Compression::kGzip},
  };
  for (const auto& [name, compression] : cases) {
    SCOPED_TRACE(name);
    auto reader = CarmenLogReader::Open((dir.path() / name).string());
    ASSERT_TRUE(reader.ok()) << reader.status();
    EXPECT_EQ((*reader)->compression(), compression);
    CheckSample(**reader);
    EXPECT_GT((*reader)->bytes_consumed(), 0);
  }
}

TEST(CarmenLog, StrictModeReturnsTheErrorAndCanGoOn) {
  ScopedTempDir dir;
  WritePlain(dir.path() / "log.clf", SampleLog());
  CarmenLogReader::Options options;
  options.skip_malformed = false;
  auto reader = CarmenLogReader::Open((dir.path() / "log.clf").string(), options);
  ASSERT_TRUE(reader.ok());
  CarmenRecord record;
  int records = 0;
  std::vector<std::string> errors;
  while (true) {
    auto more = (*reader)->Next(&record);
    if (!more.ok()) {
      EXPECT_EQ(more.status().code(), absl::StatusCode::kInvalidArgument);
      errors.emplace_back(more.status().message());
      continue;
    }
    if (!*more) break;
    ++records;
  }
  EXPECT_EQ(records, 5);
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].rfind("line 5: ", 0), 0u) << errors[0];
  EXPECT_EQ(errors[1].rfind("line 10: ", 0), 0u) << errors[1];
}

TEST(CarmenLog, ParseLineProblems) {
  CarmenRecord record;
  auto zero = ParseCarmenLine("FLASER 0 1 2 3 4 5 6 7 host 8", 7, &record);
  EXPECT_EQ(zero.status().message(), "line 7: FLASER: num_readings is 0");
  auto negative = ParseCarmenLine("FLASER -3 1 2 3", 8, &record);
  EXPECT_FALSE(negative.ok());
  EXPECT_NE(negative.status().message().find("num_readings"), std::string::npos);
  auto robot = ParseCarmenLine("ROBOTLASER1 0 -1.5 3.14 0.0174 81.9 0.01 0 3 1 2 3 0 1 2", 9,
                               &record);
  EXPECT_FALSE(robot.ok());
  EXPECT_NE(robot.status().message().find("line 9: ROBOTLASER1: expected 27 fields"),
            std::string::npos)
      << robot.status();
  auto comment = ParseCarmenLine("# FLASER 3 1 2 3", 1, &record);
  ASSERT_TRUE(comment.ok());
  EXPECT_FALSE(*comment);
  auto param = ParseCarmenLine("PARAM robot_use_laser on nohost 0", 2, &record);
  ASSERT_TRUE(param.ok());
  EXPECT_FALSE(*param);
}

TEST(CarmenLog, MissingAndCorruptFiles) {
  EXPECT_EQ(CarmenLogReader::Open("/nonexistent/log.clf").status().code(),
            absl::StatusCode::kNotFound);
  ScopedTempDir dir;
  const std::string text = SampleLog();
  WriteBzip2(dir.path() / "log.bz2", text, false);
  // Truncate the compressed file: reading ends with DATA_LOSS, not a silent short log.
  const std::string bytes = testing::ReadAll(dir.path() / "log.bz2");
  WritePlain(dir.path() / "cut.bz2", bytes.substr(0, bytes.size() / 2));
  auto reader = CarmenLogReader::Open((dir.path() / "cut.bz2").string());
  ASSERT_TRUE(reader.ok());
  CarmenRecord record;
  absl::Status status;
  while (true) {
    auto more = (*reader)->Next(&record);
    if (!more.ok()) {
      status = more.status();
      break;
    }
    if (!*more) break;
  }
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss) << status;
}

// --- the real logs (../shared/data/laser) ---

std::filesystem::path LaserData(const std::string& relative) {
  return std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "laser" / relative;
}

struct Counts {
  int odometry = 0;
  int flaser = 0;
  int robotlaser = 0;
  int malformed = 0;
  int first_beams = 0;
};

Counts CountFirst(const std::filesystem::path& path, int records, CarmenRecord* first_laser) {
  auto reader = CarmenLogReader::Open(path.string());
  EXPECT_TRUE(reader.ok()) << reader.status();
  Counts counts;
  if (!reader.ok()) return counts;
  CarmenRecord record;
  for (int i = 0; i < records; ++i) {
    auto more = (*reader)->Next(&record);
    EXPECT_TRUE(more.ok()) << more.status();
    if (!more.ok() || !*more) break;
    if (record.type == CarmenRecord::Type::kOdometry) {
      ++counts.odometry;
    } else if (record.laser.kind == CarmenLaser::Kind::kFlaser) {
      if (counts.flaser++ == 0) *first_laser = record;
    } else {
      if (counts.robotlaser++ == 0) *first_laser = record;
    }
  }
  counts.malformed = static_cast<int>((*reader)->malformed_lines());
  return counts;
}

TEST(CarmenLogRealData, FirstRecordsOfAces) {
  const auto path = LaserData("aces/aces.clf.bz2");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path << " (../shared absent)";
  CarmenRecord first;
  const Counts counts = CountFirst(path, 1000, &first);
  // ACES alternates ODOM and FLASER from the start (7375 ODOM, 7374 FLASER in the whole log).
  EXPECT_EQ(counts.odometry + counts.flaser, 1000);
  EXPECT_EQ(counts.odometry, 500);
  EXPECT_EQ(counts.flaser, 500);
  EXPECT_EQ(counts.malformed, 0);
  ASSERT_EQ(first.laser.ranges.size(), 180u);
  EXPECT_NEAR(first.laser.stamp, 70.2899, 1e-4);
  EXPECT_FLOAT_EQ(first.laser.ranges[0], 46.56f);
  EXPECT_NEAR(first.laser.odom_pose.theta, -1.570796, 1e-6);
}

TEST(CarmenLogRealData, FirstRecordsOfIntel) {
  const auto path = LaserData("intel/intel.clf.bz2");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path << " (../shared absent)";
  CarmenRecord first;
  const Counts counts = CountFirst(path, 3000, &first);
  EXPECT_EQ(counts.odometry + counts.flaser, 3000);
  EXPECT_EQ(counts.flaser, 1010);  // about one FLASER per two ODOM
  EXPECT_EQ(counts.odometry, 1990);
  EXPECT_EQ(counts.malformed, 0);
  ASSERT_EQ(first.laser.ranges.size(), 180u);
  EXPECT_NEAR(first.laser.stamp, 976052857.337530, 1e-6);
  EXPECT_FLOAT_EQ(first.laser.ranges[0], 1.07f);
  EXPECT_FLOAT_EQ(first.laser.ranges[179], 1.05f);
}

TEST(CarmenLogRealData, WholeIntelLogCounts) {
  const auto path = LaserData("intel/intel.clf.bz2");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path << " (../shared absent)";
  CarmenRecord first;
  const Counts counts = CountFirst(path, 1 << 30, &first);
  EXPECT_EQ(counts.flaser, 13631);
  EXPECT_EQ(counts.odometry, 26915);
  EXPECT_EQ(counts.malformed, 0);
}

TEST(CarmenLogRealData, RobotLaser1OfFreiburgClinic) {
  const auto path = LaserData("fr-clinic/fr-clinic_robotlaser.clf.bz2");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path << " (../shared absent)";
  CarmenRecord first;
  const Counts counts = CountFirst(path, 200, &first);
  EXPECT_EQ(counts.robotlaser, 200);
  EXPECT_EQ(counts.malformed, 0);
  EXPECT_EQ(first.laser.ranges.size(), 181u);
  EXPECT_DOUBLE_EQ(first.laser.no_return_range, 81.9);
  EXPECT_DOUBLE_EQ(first.laser.angle_min, -1.570796);
}

}  // namespace
}  // namespace waymark::adapters
