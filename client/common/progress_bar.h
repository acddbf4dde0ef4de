#ifndef WAYMARK_CLIENT_COMMON_PROGRESS_BAR_H_
#define WAYMARK_CLIENT_COMMON_PROGRESS_BAR_H_

#include <cstddef>
#include <ostream>
#include <string>
#include <string_view>

namespace waymark::cli {

// "[#####     ] 120/360 views" with `width` cells between the brackets, and ": <detail>" after
// it when a detail is given (e.g. "56 stored, 60 duplicates").
std::string FormatProgress(int done, int total, std::string_view unit, int width = 30,
                           std::string_view detail = {});

// A one-line progress bar redrawn in place with '\r'. Disabled (silent) when the stream is not a
// terminal, so logs and pipes get no control characters.
class ProgressBar {
 public:
  ProgressBar(std::ostream& out, int total, std::string unit, bool enabled);
  ~ProgressBar() { Finish(); }
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // A line shorter than the one before is padded with spaces, so no old characters remain.
  void Update(int done, std::string_view detail = {});
  // Ends the line so later output starts on a fresh one. Idempotent.
  void Finish();

 private:
  std::ostream& out_;
  int total_;
  std::string unit_;
  bool enabled_;
  bool drawn_ = false;
  size_t last_length_ = 0;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_PROGRESS_BAR_H_
