#include "tests/client/carmen_test_log.h"

#include <sstream>

namespace waymark::testing {

std::string FlaserLine(double x, double stamp) {
  std::ostringstream line;
  line << "FLASER 180";
  for (int b = 0; b < 180; ++b) line << " " << 2.0 + 0.01 * b;
  line << " " << x << " 0 0 " << x << " 0 0 " << std::fixed << stamp << " nohost 0\n";
  return line.str();
}

std::string MakeLog(int scans) {
  std::ostringstream log;
  log << "# generated\nPARAM robot_frontlaser_offset 0.0 nohost 0\n";
  for (int i = 0; i < scans; ++i) {
    const double t = 1000.0 + 0.2 * i;
    const double x = 0.1 * i;
    log << "ODOM " << x << " 0 0 0.5 0 0 " << t - 0.1 << " nohost 0\n";
    log << FlaserLine(x, t);
    if (i == 10) {  // the same stamp again: skipped
      log << "FLASER 180";
      for (int b = 0; b < 180; ++b) log << " 1.0";
      log << " 0 0 0 0 0 0 " << t << " nohost 0\n";
    }
    if (i == 20) log << "FLASER 180 1 2 3 nohost 0\n";
  }
  return log.str();
}

std::string MakeLogWithStamps(const std::vector<double>& stamps) {
  std::string log = "# generated\n";
  for (size_t i = 0; i < stamps.size(); ++i) log += FlaserLine(0.1 * static_cast<double>(i), stamps[i]);
  return log;
}

}  // namespace waymark::testing
