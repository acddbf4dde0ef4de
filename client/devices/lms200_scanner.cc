#include "client/devices/lms200_scanner.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

// Reply layouts follow the LMS2xx telegram listing as the sicktoolbox driver reads it
// (ros-drivers/sicktoolbox, c++/drivers/lms2xx/sicklms2xx/SickLMS2xx.cc):
//   - operating-mode change 0x20 -> 0xA0: the first data byte is 0x00 when the change was
//     accepted (_switchSickOperatingMode), a status byte ends the telegram;
//   - variant 0x3B -> 0xBB: 0x01 when accepted, then the scan angle (uint16 LE, degrees) and the
//     resolution (uint16 LE, hundredths of a degree) the sensor now uses, then the status byte
//     (SetSickVariant);
//   - after a rate change is acknowledged the host switches its own rate and pauses
//     (_setSessionBaud).
// An ACK (0x06) may precede any reply and a NAK (0x15) replaces it when the sensor rejects the
// telegram; Lms200Parser skips both and counts NAKs.

namespace waymark::adapters {
namespace {

constexpr std::uint8_t kModeCommand = 0x20;
constexpr std::uint8_t kStartContinuous = 0x24;
constexpr std::uint8_t kStopContinuous = 0x25;
constexpr std::uint8_t kVariantCommand = 0x3B;
constexpr std::uint8_t kScanReply = 0xB0;
constexpr std::uint8_t kReplyBit = 0x80;
constexpr std::uint16_t kScanAngleDegrees = 180;
constexpr std::size_t kReadChunk = 1024;  // bounds what one Pump adds to the parser

constexpr int kRates[] = {9600, 19200, 38400, 500000};

// The 0x20 sub-command that moves the sensor to `baud`; 0 if it has none.
std::uint8_t RateCode(int baud) {
  switch (baud) {
    case 9600:
      return 0x42;
    case 19200:
      return 0x41;
    case 38400:
      return 0x40;
    case 500000:
      return 0x48;
    default:
      return 0;
  }
}

double NowSeconds() { return absl::ToDoubleSeconds(absl::Now() - absl::UnixEpoch()); }

std::string Hex(const std::vector<std::uint8_t>& bytes) {
  return absl::StrJoin(bytes, " ", [](std::string* out, std::uint8_t b) {
    absl::StrAppend(out, absl::Hex(b, absl::kZeroPad2));
  });
}

absl::Status ValidateOptions(const Lms200Options& o) {
  if (RateCode(o.baud) == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("LMS200 baud rate must be 9600, 19200, 38400 or 500000, got ", o.baud));
  }
  if (o.reply_timeout <= absl::ZeroDuration() || o.scan_timeout <= absl::ZeroDuration() ||
      o.baud_switch_pause < absl::ZeroDuration() || o.retries < 1) {
    return absl::InvalidArgumentError(
        "LMS200 reply_timeout and scan_timeout must be positive, baud_switch_pause not negative "
        "and retries at least 1");
  }
  if (!(o.no_return_range > 0)) {
    return absl::InvalidArgumentError("LMS200 no_return_range must be positive");
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<Lms200Scanner>> Lms200Scanner::Connect(
    const std::string& device, const Lms200Options& options) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  // Open at the power-up rate; FindSensorRate moves on from there.
  auto port = SerialPort::Open(device, 9600);
  if (!port.ok()) return port.status();
  std::unique_ptr<Lms200Scanner> scanner(new Lms200Scanner(std::move(*port), options));
  if (absl::Status s = scanner->FindSensorRate(); !s.ok()) return s;
  if (absl::Status s = scanner->SetVariant(); !s.ok()) return s;
  if (absl::Status s = scanner->SwitchRate(); !s.ok()) return s;
  if (absl::Status s = scanner->StartStreaming(); !s.ok()) return s;
  return scanner;
}

Lms200Scanner::Lms200Scanner(std::unique_ptr<SerialPort> port, const Lms200Options& options)
    : port_(std::move(port)), options_(options) {
  const int steps = options.half_degree ? 2 : 1;
  layout_.angle_min = -M_PI / 2;
  layout_.angle_increment = M_PI / 180.0 / steps;
  layout_.beam_count = kScanAngleDegrees * steps + 1;
  layout_.no_return_range = options.no_return_range;
  layout_.mount = options.mount;
}

Lms200Scanner::~Lms200Scanner() {
  // Best effort: a sensor left streaming floods the line for the next run (which copes: it
  // sends the same stop first), and an unplugged cable makes this fail harmlessly.
  auto stop = EncodeLms200Telegram({kModeCommand, kStopContinuous});
  if (stop.ok()) port_->Write(*stop).IgnoreError();
}

Lms200Stats Lms200Scanner::stats() const {
  Lms200Stats s = counts_;
  s.bad_crcs += parser_.bad_crcs();
  s.naks += parser_.naks();
  s.skipped_bytes += parser_.skipped_bytes();
  return s;
}

void Lms200Scanner::ResetParser() {
  counts_.bad_crcs += parser_.bad_crcs();
  counts_.naks += parser_.naks();
  counts_.skipped_bytes += parser_.skipped_bytes();
  parser_ = Lms200Parser();
}

absl::Status Lms200Scanner::Pump(absl::Duration timeout) {
  std::uint8_t buffer[kReadChunk];
  auto n = port_->Read(buffer, sizeof(buffer), timeout);
  if (!n.ok()) return n.status();
  parser_.Feed(buffer, *n);
  return absl::OkStatus();
}

absl::StatusOr<Lms200Telegram> Lms200Scanner::Transact(
    const std::vector<std::uint8_t>& command_and_data, absl::Duration timeout, int attempts) {
  auto telegram = EncodeLms200Telegram(command_and_data);
  if (!telegram.ok()) return telegram.status();
  const std::uint8_t wanted = command_and_data[0] | kReplyBit;
  for (int attempt = 0; attempt < attempts; ++attempt) {
    if (absl::Status s = port_->Write(*telegram); !s.ok()) return s;
    const std::uint64_t naks_before = parser_.naks();
    const absl::Time deadline = absl::Now() + timeout;
    while (true) {
      while (std::optional<Lms200Telegram> reply = parser_.Next()) {
        if (reply->command == wanted) return *std::move(reply);
        ++counts_.other_telegrams;  // scans still streaming from an earlier run, say
      }
      if (parser_.naks() > naks_before) break;  // rejected: resend at once
      const absl::Duration left = deadline - absl::Now();
      if (left <= absl::ZeroDuration()) break;
      if (absl::Status s = Pump(std::min(left, absl::Milliseconds(50))); !s.ok()) return s;
    }
  }
  return absl::DeadlineExceededError(absl::StrCat("no answer from the LMS200 on ", port_->path(),
                                                  " to ", Hex(*telegram), " at ", port_->baud(),
                                                  " baud"));
}

absl::Status Lms200Scanner::SwitchMode(const std::vector<std::uint8_t>& command_and_data,
                                       const char* what) {
  auto reply = Transact(command_and_data, options_.reply_timeout, options_.retries);
  if (!reply.ok()) return reply.status();
  if (reply->data.empty() || reply->data[0] != 0x00) {
    return absl::FailedPreconditionError(absl::StrCat("the LMS200 on ", port_->path(),
                                                      " refused to ", what, " (reply data ",
                                                      Hex(reply->data), ")"));
  }
  return absl::OkStatus();
}

absl::Status Lms200Scanner::FindSensorRate() {
  // 9600 first (power-up), then the target (left over from an earlier run), then the rest.
  std::vector<int> order = {9600};
  if (options_.baud != 9600) order.push_back(options_.baud);
  for (int rate : kRates) {
    if (std::find(order.begin(), order.end(), rate) == order.end()) order.push_back(rate);
  }
  for (int rate : order) {
    if (port_->baud() != rate) {
      if (absl::Status s = port_->SetBaud(rate); !s.ok()) return s;
    }
    port_->DiscardInput();
    ResetParser();
    auto reply =
        Transact({kModeCommand, kStopContinuous}, options_.reply_timeout, options_.retries);
    if (reply.ok()) {
      if (reply->data.empty() || reply->data[0] != 0x00) {
        return absl::FailedPreconditionError(absl::StrCat(
            "the LMS200 on ", port_->path(), " answers at ", rate,
            " baud but refused to stop its output (reply data ", Hex(reply->data), ")"));
      }
      return absl::OkStatus();
    }
    if (reply.status().code() != absl::StatusCode::kDeadlineExceeded) return reply.status();
  }
  return absl::UnavailableError(absl::StrCat(
      "no answer from the LMS200 on ", port_->path(), " at ", absl::StrJoin(order, ", "),
      " baud: is it powered (it takes ~30 s to boot) and is the cable RS-232/RS-422 as "
      "configured?"));
}

absl::Status Lms200Scanner::SetVariant() {
  const std::uint16_t resolution = options_.half_degree ? 50 : 100;  // 1/100 degree
  auto reply = Transact(
      {kVariantCommand, kScanAngleDegrees & 0xFF, kScanAngleDegrees >> 8,
       static_cast<std::uint8_t>(resolution & 0xFF), static_cast<std::uint8_t>(resolution >> 8)},
      options_.reply_timeout, options_.retries);
  if (!reply.ok()) return reply.status();
  const std::vector<std::uint8_t>& d = reply->data;
  const bool echoed = d.size() >= 5 && d[0] == 0x01 && (d[1] | (d[2] << 8)) == kScanAngleDegrees &&
                      (d[3] | (d[4] << 8)) == resolution;
  if (!echoed) {
    return absl::FailedPreconditionError(
        absl::StrCat("the LMS200 on ", port_->path(), " did not accept the variant 180 degrees at ",
                     resolution / 100.0, " degree (reply data ", Hex(d), ")"));
  }
  return absl::OkStatus();
}

absl::Status Lms200Scanner::SwitchRate() {
  if (port_->baud() == options_.baud) return absl::OkStatus();
  // The laser first, at the rate it listens at now; the host only once the laser has answered.
  if (absl::Status s = SwitchMode({kModeCommand, RateCode(options_.baud)},
                                  absl::StrCat("switch to ", options_.baud, " baud").c_str());
      !s.ok()) {
    return s;
  }
  if (absl::Status s = port_->SetBaud(options_.baud); !s.ok()) return s;
  absl::SleepFor(options_.baud_switch_pause);
  port_->DiscardInput();
  ResetParser();
  return absl::OkStatus();
}

absl::Status Lms200Scanner::StartStreaming() {
  return SwitchMode({kModeCommand, kStartContinuous}, "start continuous output");
}

absl::StatusOr<LaserReading> Lms200Scanner::Read() {
  const absl::Time deadline = absl::Now() + options_.scan_timeout;
  while (true) {
    while (std::optional<Lms200Telegram> telegram = parser_.Next()) {
      if (telegram->command != kScanReply) {
        ++counts_.other_telegrams;
        continue;
      }
      auto scan = DecodeLms200Scan(*telegram);
      // A malformed scan (truncated, unknown units) is as useless as one of the wrong size.
      if (!scan.ok() || scan->ranges_m.size() != layout_.beam_count) {
        ++counts_.wrong_size_scans;
        continue;
      }
      ++counts_.scans;
      LaserReading reading;
      reading.stamp = NowSeconds();
      reading.ranges = std::move(scan->ranges_m);
      return reading;
    }
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) {
      return absl::UnavailableError(
          absl::StrCat("no scan from the LMS200 on ", port_->path(), " for ",
                       absl::FormatDuration(options_.scan_timeout), " (", port_->baud(),
                       " baud): is it still powered and streaming?"));
    }
    if (absl::Status s = Pump(std::min(left, absl::Milliseconds(100))); !s.ok()) return s;
  }
}

}  // namespace waymark::adapters
