#ifndef WAYMARK_TESTS_CLIENT_CARMEN_TEST_LOG_H_
#define WAYMARK_TESTS_CLIENT_CARMEN_TEST_LOG_H_

// Small CARMEN logs for the slam command tests.

#include <string>
#include <vector>

namespace waymark::testing {

// One FLASER line of 180 beams (2.0 m + 1 cm per beam) at odometry (x, 0, 0), stamped `stamp`.
std::string FlaserLine(double x, double stamp);

// `scans` FLASER lines driving along x 0.1 m apart, stamped 1000 + 0.2 i, with ODOM lines between
// them, one repeated stamp (after line 10) and one malformed line (after line 20).
std::string MakeLog(int scans);

// One FLASER line per stamp, driving along x 0.1 m apart, no ODOM lines.
std::string MakeLogWithStamps(const std::vector<double>& stamps);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_CLIENT_CARMEN_TEST_LOG_H_
