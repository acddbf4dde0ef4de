#ifndef WAYMARK_CLIENT_COMMON_PROGRESS_BAR_H_
#define WAYMARK_CLIENT_COMMON_PROGRESS_BAR_H_

#include <ostream>
#include <string>
#include <string_view>

namespace waymark::cli {

// "[#####     ] 120/360 views" with `width` cells between the brackets.
std::string FormatProgress(int done, int total, std::string_view unit, int width = 30);

// A one-line progress bar redrawn in place with '\r'. Disabled (silent) when the stream is not a
// terminal, so logs and pipes get no control characters.
class ProgressBar {
 public:
  ProgressBar(std::ostream& out, int total, std::string unit, bool enabled);
  ~ProgressBar() { Finish(); }
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void Update(int done);
  // Ends the line so later output starts on a fresh one. Idempotent.
  void Finish();

 private:
  std::ostream& out_;
  int total_;
  std::string unit_;
  bool enabled_;
  bool drawn_ = false;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_PROGRESS_BAR_H_
