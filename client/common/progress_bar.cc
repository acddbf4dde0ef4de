#include "client/common/progress_bar.h"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace waymark::cli {

std::string FormatProgress(int done, int total, std::string_view unit, int width) {
  const int filled = total > 0 ? std::clamp(done, 0, total) * width / total : width;
  return fmt::format("[{}{}] {}/{} {}", std::string(filled, '#'), std::string(width - filled, ' '),
                     done, total, unit);
}

ProgressBar::ProgressBar(std::ostream& out, int total, std::string unit, bool enabled)
    : out_(out), total_(total), unit_(std::move(unit)), enabled_(enabled) {}

void ProgressBar::Update(int done) {
  if (!enabled_) return;
  out_ << '\r' << FormatProgress(done, total_, unit_) << std::flush;
  drawn_ = true;
}

void ProgressBar::Finish() {
  if (drawn_) out_ << '\n' << std::flush;
  drawn_ = false;
}

}  // namespace waymark::cli
