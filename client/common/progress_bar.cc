#include "client/common/progress_bar.h"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace waymark::cli {

std::string FormatProgress(int done, int total, std::string_view unit, int width,
                           std::string_view detail) {
  const int filled = total > 0 ? std::clamp(done, 0, total) * width / total : width;
  std::string line = fmt::format("[{}{}] {}/{} {}", std::string(filled, '#'),
                                 std::string(width - filled, ' '), done, total, unit);
  if (!detail.empty()) line += fmt::format(": {}", detail);
  return line;
}

ProgressBar::ProgressBar(std::ostream& out, int total, std::string unit, bool enabled)
    : out_(out), total_(total), unit_(std::move(unit)), enabled_(enabled) {}

void ProgressBar::Update(int done, std::string_view detail) {
  if (!enabled_) return;
  const std::string line = FormatProgress(done, total_, unit_, 30, detail);
  const size_t padding = last_length_ > line.size() ? last_length_ - line.size() : 0;
  out_ << '\r' << line << std::string(padding, ' ') << std::flush;
  last_length_ = line.size();
  drawn_ = true;
}

void ProgressBar::Finish() {
  if (drawn_) out_ << '\n' << std::flush;
  drawn_ = false;
  last_length_ = 0;
}

}  // namespace waymark::cli
