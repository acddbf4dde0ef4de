#include "tests/robot/fake_lms200_peer.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <utility>

#include "client/devices/lms200_telegram.h"

namespace waymark::testing {
namespace {

using adapters::EncodeLms200Telegram;
using adapters::Lms200Parser;
using adapters::Lms200Telegram;

constexpr std::uint8_t kFromSensor = 0x80;
constexpr std::uint8_t kStatusOk = 0x10;  // the status byte closing each reply
constexpr absl::Duration kIdlePoll = absl::Milliseconds(5);
constexpr absl::Duration kWriteGiveUp = absl::Milliseconds(500);

// The rate a 20 xx sub-command selects; 0 if it is no rate command.
int RateOf(std::uint8_t code) {
  switch (code) {
    case 0x40:
      return 38400;
    case 0x41:
      return 19200;
    case 0x42:
      return 9600;
    case 0x48:
      return 500000;
    default:
      return 0;
  }
}

std::vector<std::uint8_t> Reply(const std::vector<std::uint8_t>& command_and_data) {
  auto telegram = EncodeLms200Telegram(command_and_data, kFromSensor);
  return telegram.ok() ? *telegram : std::vector<std::uint8_t>{};
}

}  // namespace

absl::StatusOr<std::unique_ptr<FakeLms200Peer>> FakeLms200Peer::Start(FakeLms200Options options) {
  auto pty = PtyPair::Open();
  if (!pty.ok()) return pty.status();
  return std::unique_ptr<FakeLms200Peer>(new FakeLms200Peer(std::move(*pty), std::move(options)));
}

FakeLms200Peer::FakeLms200Peer(PtyPair pty, FakeLms200Options options)
    : pty_(std::move(pty)),
      device_path_(pty_.device_path()),
      options_(std::move(options)),
      baud_(options_.baud),
      streaming_(options_.streaming),
      resolution_(options_.half_degree ? 50 : 100) {
  // Non-blocking writes: a driver that stops reading must not wedge the peer's thread.
  const int flags = fcntl(pty_.master_fd(), F_GETFL);
  fcntl(pty_.master_fd(), F_SETFL, flags | O_NONBLOCK);
  rate_events_.push_back({true, baud_});
  thread_ = std::thread([this] { Run(); });
}

FakeLms200Peer::~FakeLms200Peer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void FakeLms200Peer::Hangup() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  pty_.Hangup();  // only this thread touches the pty once the peer has stopped
}

std::vector<FakeLms200Heard> FakeLms200Peer::heard() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return heard_;
}

std::vector<std::vector<std::uint8_t>> FakeLms200Peer::commands() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::vector<std::uint8_t>> out;
  for (const FakeLms200Heard& h : heard_) {
    if (h.telegram.size() >= 7) out.emplace_back(h.telegram.begin() + 4, h.telegram.end() - 2);
  }
  return out;
}

std::vector<FakeLms200RateEvent> FakeLms200Peer::rate_events() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return rate_events_;
}

int FakeLms200Peer::baud() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return baud_;
}

bool FakeLms200Peer::streaming() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return streaming_;
}

int FakeLms200Peer::beam_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return angle_ * 100 / resolution_ + 1;
}

std::uint64_t FakeLms200Peer::scans_sent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scans_sent_;
}

std::uint64_t FakeLms200Peer::ignored_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return ignored_bytes_;
}

void FakeLms200Peer::SendGarbage(std::vector<std::uint8_t> bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  faults_.push_back(std::move(bytes));
}

void FakeLms200Peer::SendBadCrcScan() {
  std::vector<std::uint8_t> scan = Scan(beam_count());
  scan.back() ^= 0x01;
  std::lock_guard<std::mutex> lock(mutex_);
  faults_.push_back(std::move(scan));
}

void FakeLms200Peer::SendNak() {
  std::lock_guard<std::mutex> lock(mutex_);
  faults_.push_back({adapters::lms200::kNak});
}

void FakeLms200Peer::SendScanOfSize(int beam_count) {
  std::vector<std::uint8_t> scan = Scan(beam_count);
  std::lock_guard<std::mutex> lock(mutex_);
  faults_.push_back(std::move(scan));
}

void FakeLms200Peer::Mute() {
  std::lock_guard<std::mutex> lock(mutex_);
  muted_ = true;
}

void FakeLms200Peer::NakNextCommands(int count) {
  std::lock_guard<std::mutex> lock(mutex_);
  naks_to_send_ += count;
}

std::vector<std::uint8_t> FakeLms200Peer::Scan(int beam_count) const {
  // B0, count word (low 11 bits the count, bit 14 = mm units), uint16 values, status byte.
  const int word = (beam_count & 0x07FF) | (1 << 14);
  std::vector<std::uint8_t> body = {0xB0, static_cast<std::uint8_t>(word & 0xFF),
                                    static_cast<std::uint8_t>(word >> 8)};
  for (int beam = 0; beam < beam_count; ++beam) {
    const std::uint16_t mm = options_.range_mm ? options_.range_mm(beam, beam_count) : 1000 + beam;
    body.push_back(static_cast<std::uint8_t>(mm & 0xFF));
    body.push_back(static_cast<std::uint8_t>((mm >> 8) & 0x1F));
  }
  body.push_back(kStatusOk);
  return Reply(body);
}

void FakeLms200Peer::PollHostRate() {
  const int host = pty_.host_baud();
  std::lock_guard<std::mutex> lock(mutex_);
  if (host != last_host_baud_) {
    last_host_baud_ = host;
    rate_events_.push_back({false, host});
  }
}

bool FakeLms200Peer::Send(const std::vector<std::uint8_t>& bytes) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (muted_) return false;
  }
  if (pty_.host_baud() != baud()) return false;  // the host would only see noise
  const absl::Time give_up = absl::Now() + kWriteGiveUp;
  std::size_t done = 0;
  while (done < bytes.size() && !stop_ && absl::Now() < give_up) {
    const ssize_t n = ::write(pty_.master_fd(), bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
      pollfd p{pty_.master_fd(), POLLOUT, 0};
      ::poll(&p, 1, 20);
    } else {
      return false;
    }
  }
  return done == bytes.size();
}

void FakeLms200Peer::Handle(const std::vector<std::uint8_t>& command_and_data) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (naks_to_send_ > 0) {
      --naks_to_send_;
      faults_.push_front({adapters::lms200::kNak});
      return;
    }
  }
  const std::uint8_t command = command_and_data[0];
  std::vector<std::uint8_t> answer = {adapters::lms200::kAck};
  int new_rate = 0;
  if (command == 0x20 && command_and_data.size() == 2) {
    const std::uint8_t mode = command_and_data[1];
    new_rate = RateOf(mode);
    const bool known = new_rate != 0 || mode == 0x24 || mode == 0x25;
    const std::vector<std::uint8_t> reply =
        Reply({0xA0, known ? std::uint8_t{0x00} : std::uint8_t{0x01}, kStatusOk});
    answer.insert(answer.end(), reply.begin(), reply.end());
    if (mode == 0x24 || mode == 0x25) {
      std::lock_guard<std::mutex> lock(mutex_);
      streaming_ = mode == 0x24;
    }
  } else if (command == 0x3B && command_and_data.size() == 5) {
    const int angle = command_and_data[1] | (command_and_data[2] << 8);
    const int resolution = command_and_data[3] | (command_and_data[4] << 8);
    const bool ok = (angle == 180 && (resolution == 100 || resolution == 50)) ||
                    (angle == 100 && (resolution == 100 || resolution == 50 || resolution == 25));
    std::lock_guard<std::mutex> lock(mutex_);
    if (ok) {
      angle_ = angle;
      resolution_ = resolution;
    }
    const std::vector<std::uint8_t> reply =
        Reply({0xBB, static_cast<std::uint8_t>(ok ? 0x01 : 0x00),
               static_cast<std::uint8_t>(angle_ & 0xFF), static_cast<std::uint8_t>(angle_ >> 8),
               static_cast<std::uint8_t>(resolution_ & 0xFF),
               static_cast<std::uint8_t>(resolution_ >> 8), kStatusOk});
    answer.insert(answer.end(), reply.begin(), reply.end());
  } else {
    answer = {adapters::lms200::kNak};
  }
  Send(answer);
  if (new_rate != 0) {
    // The sensor answers at the old rate, then switches.
    std::lock_guard<std::mutex> lock(mutex_);
    baud_ = new_rate;
    rate_events_.push_back({true, new_rate});
  }
}

void FakeLms200Peer::Run() {
  Lms200Parser parser;
  absl::Time next_scan = absl::Now();
  while (!stop_) {
    PollHostRate();
    const std::vector<std::uint8_t> bytes = pty_.ReadSome(kIdlePoll);
    if (!bytes.empty()) {
      // The host set its rate before writing these: log a change before what it sent.
      PollHostRate();
      if (pty_.host_baud() == baud()) {
        parser.Feed(bytes.data(), bytes.size());
      } else {
        std::lock_guard<std::mutex> lock(mutex_);
        ignored_bytes_ += bytes.size();
      }
    }
    while (std::optional<Lms200Telegram> telegram = parser.Next()) {
      std::vector<std::uint8_t> body;
      body.reserve(1 + telegram->data.size());
      body.push_back(telegram->command);
      body.insert(body.end(), telegram->data.begin(), telegram->data.end());
      {
        std::lock_guard<std::mutex> lock(mutex_);
        auto whole = EncodeLms200Telegram(body, telegram->address);  // CRC checked: identical
        heard_.push_back({whole.ok() ? *whole : body, baud_});
      }
      Handle(body);
    }
    std::vector<std::vector<std::uint8_t>> faults;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      faults.assign(faults_.begin(), faults_.end());
      faults_.clear();
    }
    for (const auto& fault : faults) Send(fault);
    if (streaming() && absl::Now() >= next_scan) {
      next_scan = absl::Now() + options_.scan_period;
      if (Send(Scan(beam_count()))) {
        std::lock_guard<std::mutex> lock(mutex_);
        ++scans_sent_;
      }
    }
  }
}

std::uint16_t RoomRangeMm(int beam, int beam_count) {
  const double angle = -M_PI / 2 + beam * M_PI / (beam_count - 1);
  const double c = std::cos(angle), s = std::sin(angle);
  double range = 8.0;
  if (c > 1e-9) range = std::min(range, 3.0 / c);
  if (c < -1e-9) range = std::min(range, -2.0 / c);
  if (s > 1e-9) range = std::min(range, 1.5 / s);
  if (s < -1e-9) range = std::min(range, -1.5 / s);
  return static_cast<std::uint16_t>(std::lround(range * 1000));
}

}  // namespace waymark::testing
