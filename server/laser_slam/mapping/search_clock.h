#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_SEARCH_CLOCK_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_SEARCH_CLOCK_H_

// The clock a rate-limited search runs on (the tie's global searches, trajectory_tie.h): cell
// reads granted by a robot's scans, counted from its nodes' scan numbers and stamps. Each scan
// grants reads_per_scan, or reads_per_second for every second of the robot's own clock between
// the nodes around it where that is more. A robot that logs a keyframe every metre (one scan in
// seconds) then gets its searches by the second, as a robot scanning at 5 Hz does, and not a few
// hundred scans' worth over a whole building; a robot that scans faster gets what its scans grant.
//
// The position on the clock is a scan number (fractional: part of the way to the next scan), so
// the same nodes give the same searches however the calls that spend the reads are spread.

#include <cstdint>
#include <vector>

#include "server/laser_slam/mapping/mapping_backend.h"

namespace waymark::laser_slam {

struct SearchClockRates {
  double reads_per_scan = 0.0;
  double reads_per_second = 0.0;  // 0: the scans alone
};

// The reads the scans in (from, to] grant (0 when to <= from). `nodes`: oldest first, scans
// increasing; a scan outside them grants reads_per_scan.
double ReadsGranted(const std::vector<NodeView>& nodes, const SearchClockRates& rates,
                    double from, double to);

// Where the clock stands after `reads` more from `from`: the scan whose grants since `from` add
// up to them.
double ClockAfter(const std::vector<NodeView>& nodes, const SearchClockRates& rates, double from,
                  double reads);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_SEARCH_CLOCK_H_
