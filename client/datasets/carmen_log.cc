#include "client/datasets/carmen_log.h"

#include <bzlib.h>
#include <zlib.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include "absl/strings/string_view.h"

#include "absl/strings/str_cat.h"

namespace waymark::adapters {

// Bytes of the decompressed log, in chunks.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Up to `size` bytes into `data`; 0 at the end; DATA_LOSS on a corrupt stream.
  virtual absl::StatusOr<size_t> Read(char* data, size_t size) = 0;
  virtual int64_t Consumed() const = 0;
};

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr size_t kChunk = 1 << 16;

class PlainSource final : public ByteSource {
 public:
  explicit PlainSource(FILE* file) : file_(file) {}
  ~PlainSource() override { std::fclose(file_); }
  absl::StatusOr<size_t> Read(char* data, size_t size) override {
    const size_t n = std::fread(data, 1, size, file_);
    if (n == 0 && std::ferror(file_)) return absl::DataLossError("read error");
    return n;
  }
  int64_t Consumed() const override { return std::ftell(file_); }

 private:
  FILE* file_;
};

class GzipSource final : public ByteSource {
 public:
  explicit GzipSource(gzFile file) : file_(file) { gzbuffer(file_, 1 << 18); }
  ~GzipSource() override { gzclose(file_); }
  absl::StatusOr<size_t> Read(char* data, size_t size) override {
    const int n = gzread(file_, data, static_cast<unsigned>(size));
    if (n < 0) {
      int code = 0;
      const char* message = gzerror(file_, &code);
      return absl::DataLossError(absl::StrCat("gzip: ", message ? message : "read error"));
    }
    // gzread returns a short count at a truncated end without an error; gzerror tells.
    if (n == 0) {
      int code = 0;
      const char* message = gzerror(file_, &code);
      if (code != Z_OK && code != Z_STREAM_END) {
        return absl::DataLossError(absl::StrCat("gzip: ", message ? message : "read error"));
      }
    }
    return static_cast<size_t>(n);
  }
  int64_t Consumed() const override { return gzoffset(file_); }

 private:
  gzFile file_;
};

// bzip2 over a FILE*, following concatenated streams (as pbzip2 writes them).
class Bzip2Source final : public ByteSource {
 public:
  explicit Bzip2Source(FILE* file) : file_(file) {}
  ~Bzip2Source() override {
    if (bz_ != nullptr) {
      int error = BZ_OK;
      BZ2_bzReadClose(&error, bz_);
    }
    std::fclose(file_);
  }
  absl::StatusOr<size_t> Read(char* data, size_t size) override {
    while (true) {
      if (done_) return 0;
      if (bz_ == nullptr) {
        int error = BZ_OK;
        bz_ = BZ2_bzReadOpen(&error, file_, 0, 0, unused_.data(), static_cast<int>(unused_.size()));
        if (error != BZ_OK) return absl::DataLossError(absl::StrCat("bzip2: open error ", error));
      }
      int error = BZ_OK;
      const int n = BZ2_bzRead(&error, bz_, data, static_cast<int>(size));
      if (error == BZ_OK) {
        if (n > 0) return static_cast<size_t>(n);
        continue;
      }
      if (error != BZ_STREAM_END) {
        return absl::DataLossError(
            absl::StrCat("bzip2: ", error == BZ_UNEXPECTED_EOF ? "truncated stream"
                                                               : "corrupt stream",
                         " (error ", error, ")"));
      }
      // End of one stream: keep the bytes read past it, and go on if more follow.
      void* unused = nullptr;
      int unused_count = 0;
      BZ2_bzReadGetUnused(&error, bz_, &unused, &unused_count);
      std::string rest(static_cast<const char*>(unused), unused_count);
      BZ2_bzReadClose(&error, bz_);
      bz_ = nullptr;
      unused_ = std::move(rest);
      if (unused_.empty()) {
        const int c = std::fgetc(file_);
        if (c == EOF) {
          done_ = true;
        } else {
          std::ungetc(c, file_);
        }
      }
      if (n > 0) return static_cast<size_t>(n);
    }
  }
  int64_t Consumed() const override { return std::ftell(file_); }

 private:
  FILE* file_;
  BZFILE* bz_ = nullptr;
  std::string unused_;
  bool done_ = false;
};

// Whitespace-separated fields, as views into the line.
void SplitFields(absl::string_view line, std::vector<absl::string_view>* fields) {
  fields->clear();
  size_t i = 0;
  const size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= n) break;
    const size_t start = i;
    while (i < n && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    fields->push_back(line.substr(start, i - start));
  }
}

absl::Status Malformed(int64_t line_number, absl::string_view type, absl::string_view problem) {
  return absl::InvalidArgumentError(absl::StrCat("line ", line_number, ": ", type, ": ", problem));
}

// Field parsing with the message naming the field.
class FieldParser {
 public:
  FieldParser(const std::vector<absl::string_view>& fields, int64_t line_number,
              absl::string_view type)
      : fields_(fields), line_number_(line_number), type_(type) {}

  absl::Status Double(size_t index, absl::string_view name, double* value) const {
    if (index >= fields_.size()) {
      return Malformed(line_number_, type_, absl::StrCat("missing field ", name));
    }
    const absl::string_view text = fields_[index];
    const char* begin = text.data();
    const char* end = begin + text.size();
    if (begin != end && *begin == '+') ++begin;
    const auto result = std::from_chars(begin, end, *value);
    if (result.ec != std::errc() || result.ptr != end) {
      // Very large or small values (out of double range) are errors too.
      return Malformed(line_number_, type_,
                       absl::StrCat("field ", index + 1, " (", name, ") is not a number: '", text,
                                    "'"));
    }
    return absl::OkStatus();
  }

  absl::Status Count(size_t index, absl::string_view name, int max, int* value) const {
    if (index >= fields_.size()) {
      return Malformed(line_number_, type_, absl::StrCat("missing field ", name));
    }
    const absl::string_view text = fields_[index];
    const auto result = std::from_chars(text.data(), text.data() + text.size(), *value);
    if (result.ec != std::errc() || result.ptr != text.data() + text.size() || *value < 0 ||
        *value > max) {
      return Malformed(line_number_, type_,
                       absl::StrCat("field ", index + 1, " (", name,
                                    ") is not a count in [0, ", max, "]: '", text, "'"));
    }
    return absl::OkStatus();
  }

  absl::Status Pose(size_t index, absl::string_view name, CarmenPose* pose) const {
    if (auto s = Double(index, absl::StrCat(name, "_x"), &pose->x); !s.ok()) return s;
    if (auto s = Double(index + 1, absl::StrCat(name, "_y"), &pose->y); !s.ok()) return s;
    return Double(index + 2, absl::StrCat(name, "_theta"), &pose->theta);
  }

  absl::Status Ranges(size_t index, int count, std::vector<float>* ranges) const {
    ranges->resize(count);
    for (int i = 0; i < count; ++i) {
      double r = 0;
      if (auto s = Double(index + i, absl::StrCat("range ", i + 1), &r); !s.ok()) return s;
      (*ranges)[i] = static_cast<float>(r);
    }
    return absl::OkStatus();
  }

  absl::Status Error(absl::string_view problem) const {
    return Malformed(line_number_, type_, problem);
  }

  // Checks the field count: the message body plus `ts host ts`.
  absl::Status Expect(size_t count) const {
    if (fields_.size() != count) {
      return Malformed(line_number_, type_,
                       absl::StrCat("expected ", count, " fields, got ", fields_.size()));
    }
    return absl::OkStatus();
  }

 private:
  const std::vector<absl::string_view>& fields_;
  int64_t line_number_;
  absl::string_view type_;
};

constexpr int kMaxBeams = 100000;

absl::Status ParseOdom(const FieldParser& p, CarmenOdometry* odom) {
  // ODOM x y theta tv rv accel ts host ts
  if (auto s = p.Expect(10); !s.ok()) return s;
  if (auto s = p.Pose(1, "odom", &odom->pose); !s.ok()) return s;
  if (auto s = p.Double(4, "tv", &odom->tv); !s.ok()) return s;
  if (auto s = p.Double(5, "rv", &odom->rv); !s.ok()) return s;
  return p.Double(7, "ipc_timestamp", &odom->stamp);
}

absl::Status ParseFlaser(const FieldParser& p, CarmenLaser* laser) {
  int n = 0;
  if (auto s = p.Count(1, "num_readings", kMaxBeams, &n); !s.ok()) return s;
  if (n == 0) return p.Error("num_readings is 0");
  if (auto s = p.Expect(static_cast<size_t>(n) + 11); !s.ok()) return s;
  laser->kind = CarmenLaser::Kind::kFlaser;
  if (auto s = p.Ranges(2, n, &laser->ranges); !s.ok()) return s;
  if (auto s = p.Pose(2 + n, "laser", &laser->laser_pose); !s.ok()) return s;
  if (auto s = p.Pose(5 + n, "odom", &laser->odom_pose); !s.ok()) return s;
  if (auto s = p.Double(8 + n, "ipc_timestamp", &laser->stamp); !s.ok()) return s;
  laser->angle_min = kFlaserAngleMin;
  laser->angle_increment = FlaserAngleIncrement(n);
  laser->no_return_range = 0;
  return absl::OkStatus();
}

absl::Status ParseRobotLaser1(const FieldParser& p, int64_t line_number, CarmenLaser* laser) {
  // ROBOTLASER1 type start fov res max_range accuracy remission_mode n r.. n_rem rem.. laser(3)
  // robot(3) tv rv forward_safety side_safety turn_axis ts host ts
  double fov = 0;
  int n = 0;
  laser->kind = CarmenLaser::Kind::kRobotLaser1;
  if (auto s = p.Double(2, "start_angle", &laser->angle_min); !s.ok()) return s;
  if (auto s = p.Double(3, "fov", &fov); !s.ok()) return s;
  if (auto s = p.Double(4, "angular_res", &laser->angle_increment); !s.ok()) return s;
  if (auto s = p.Double(5, "max_range", &laser->no_return_range); !s.ok()) return s;
  if (auto s = p.Count(8, "num_readings", kMaxBeams, &n); !s.ok()) return s;
  if (!(laser->angle_increment > 0) || !std::isfinite(laser->angle_increment)) {
    return Malformed(line_number, "ROBOTLASER1", "angular_res must be positive");
  }
  if (auto s = p.Ranges(9, n, &laser->ranges); !s.ok()) return s;
  int remissions = 0;
  if (auto s = p.Count(9 + n, "num_remissions", kMaxBeams, &remissions); !s.ok()) return s;
  const size_t after = 10 + static_cast<size_t>(n) + remissions;
  if (auto s = p.Expect(after + 14); !s.ok()) return s;
  if (auto s = p.Pose(after, "laser", &laser->laser_pose); !s.ok()) return s;
  if (auto s = p.Pose(after + 3, "robot", &laser->odom_pose); !s.ok()) return s;
  return p.Double(after + 11, "ipc_timestamp", &laser->stamp);
}

}  // namespace

double FlaserAngleIncrement(int beam_count) {
  if (beam_count == 180 || beam_count == 181) return kPi / 180.0;
  if (beam_count == 360 || beam_count == 361) return kPi / 360.0;
  return beam_count > 0 ? kPi / beam_count : 0.0;
}

absl::StatusOr<bool> ParseCarmenLine(const std::string& line, int64_t line_number,
                                     CarmenRecord* record) {
  thread_local std::vector<absl::string_view> fields;
  SplitFields(line, &fields);
  if (fields.empty() || fields[0][0] == '#') return false;
  const absl::string_view type = fields[0];
  const FieldParser parser(fields, line_number, type);
  record->line = line_number;
  if (type == "ODOM") {
    record->type = CarmenRecord::Type::kOdometry;
    if (auto s = ParseOdom(parser, &record->odometry); !s.ok()) return s;
  } else if (type == "FLASER") {
    record->type = CarmenRecord::Type::kLaser;
    if (auto s = ParseFlaser(parser, &record->laser); !s.ok()) return s;
  } else if (type == "ROBOTLASER1") {
    record->type = CarmenRecord::Type::kLaser;
    if (auto s = ParseRobotLaser1(parser, line_number, &record->laser); !s.ok()) return s;
  } else {
    return false;  // PARAM, NEFF, SYNC, RLASER, ... carry nothing the replay uses
  }
  const double stamp = record->type == CarmenRecord::Type::kOdometry ? record->odometry.stamp
                                                                     : record->laser.stamp;
  if (!std::isfinite(stamp)) return Malformed(line_number, type, "ipc_timestamp is not finite");
  return true;
}

absl::StatusOr<std::unique_ptr<CarmenLogReader>> CarmenLogReader::Open(const std::string& path) {
  return Open(path, Options{});
}

absl::StatusOr<std::unique_ptr<CarmenLogReader>> CarmenLogReader::Open(const std::string& path,
                                                                       Options options) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return absl::NotFoundError(absl::StrCat("no log file '", path, "'"));
  }
  if (std::filesystem::is_directory(path, ec)) {
    return absl::InvalidArgumentError(absl::StrCat("'", path, "' is a directory, not a log"));
  }
  FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) {
    return absl::PermissionDeniedError(
        absl::StrCat("cannot read '", path, "': ", std::strerror(errno)));
  }
  unsigned char magic[3] = {0, 0, 0};
  const size_t got = std::fread(magic, 1, 3, file);
  std::rewind(file);

  std::unique_ptr<CarmenLogReader> reader(new CarmenLogReader());
  reader->options_ = options;
  reader->file_size_ = static_cast<int64_t>(std::filesystem::file_size(path, ec));
  if (got >= 2 && magic[0] == 0x1f && magic[1] == 0x8b) {
    std::fclose(file);
    gzFile gz = gzopen(path.c_str(), "rb");
    if (gz == nullptr) return absl::PermissionDeniedError(absl::StrCat("cannot open '", path, "'"));
    reader->compression_ = Compression::kGzip;
    reader->source_ = std::make_unique<GzipSource>(gz);
  } else if (got == 3 && magic[0] == 'B' && magic[1] == 'Z' && magic[2] == 'h') {
    reader->compression_ = Compression::kBzip2;
    reader->source_ = std::make_unique<Bzip2Source>(file);
  } else {
    reader->compression_ = Compression::kPlain;
    reader->source_ = std::make_unique<PlainSource>(file);
  }
  return reader;
}

CarmenLogReader::~CarmenLogReader() = default;

int64_t CarmenLogReader::bytes_consumed() const { return source_->Consumed(); }

absl::StatusOr<bool> CarmenLogReader::ReadLine() {
  line_.clear();
  while (true) {
    if (buffer_pos_ < buffer_.size()) {
      const char* begin = buffer_.data() + buffer_pos_;
      const size_t available = buffer_.size() - buffer_pos_;
      const void* newline = std::memchr(begin, '\n', available);
      if (newline != nullptr) {
        const size_t length = static_cast<const char*>(newline) - begin;
        line_.append(begin, length);
        buffer_pos_ += length + 1;
        return true;
      }
      line_.append(begin, available);
      buffer_pos_ = buffer_.size();
    }
    if (eof_) return !line_.empty();  // a last line without a newline
    buffer_.resize(kChunk);
    auto n = source_->Read(buffer_.data(), buffer_.size());
    if (!n.ok()) {
      return absl::DataLossError(
          absl::StrCat("after line ", line_number_, ": ", n.status().message()));
    }
    buffer_.resize(*n);
    buffer_pos_ = 0;
    if (*n == 0) eof_ = true;
  }
}

absl::StatusOr<bool> CarmenLogReader::Next(CarmenRecord* record) {
  while (true) {
    auto more = ReadLine();
    if (!more.ok()) return more.status();
    if (!*more) return false;
    ++line_number_;
    auto parsed = ParseCarmenLine(line_, line_number_, record);
    if (parsed.ok()) {
      if (*parsed) return true;
      continue;
    }
    ++malformed_;
    if (first_errors_.size() < kMaxErrorsKept) {
      first_errors_.emplace_back(parsed.status().message());
    }
    if (!options_.skip_malformed) return parsed.status();
  }
}

}  // namespace waymark::adapters
