#include "server/laser_slam/mapping/search_clock.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace waymark::laser_slam {
namespace {

// The reads per scan granted between nodes i and i + 1 (-1 and nodes.size() - 1: before the
// first node and after the last, where there is no stamp to go by).
double RateAfterNode(const std::vector<NodeView>& nodes, const SearchClockRates& rates,
                     std::ptrdiff_t i) {
  if (i < 0 || i + 1 >= static_cast<std::ptrdiff_t>(nodes.size())) return rates.reads_per_scan;
  const double scans = static_cast<double>(nodes[i + 1].scan) - static_cast<double>(nodes[i].scan);
  const double seconds = nodes[i + 1].stamp - nodes[i].stamp;
  if (!(scans > 0) || !(seconds > 0) || !std::isfinite(seconds)) return rates.reads_per_scan;
  return std::max(rates.reads_per_scan, rates.reads_per_second * seconds / scans);
}

// The node interval holding `scan`: the last node at or before it (-1: before the first).
std::ptrdiff_t IntervalOf(const std::vector<NodeView>& nodes, double scan) {
  const auto after = std::upper_bound(
      nodes.begin(), nodes.end(), scan,
      [](double s, const NodeView& node) { return s < static_cast<double>(node.scan); });
  return (after - nodes.begin()) - 1;
}

// Where interval i ends (the next node's scan; infinity after the last).
double IntervalEnd(const std::vector<NodeView>& nodes, std::ptrdiff_t i) {
  if (i + 1 >= static_cast<std::ptrdiff_t>(nodes.size())) {
    return std::numeric_limits<double>::infinity();
  }
  return static_cast<double>(nodes[i + 1].scan);
}

}  // namespace

double ReadsGranted(const std::vector<NodeView>& nodes, const SearchClockRates& rates,
                    double from, double to) {
  double reads = 0.0;
  for (std::ptrdiff_t i = IntervalOf(nodes, from); from < to; ++i) {
    const double end = std::min(to, IntervalEnd(nodes, i));
    reads += (end - from) * RateAfterNode(nodes, rates, i);
    from = end;
  }
  return reads;
}

double ClockAfter(const std::vector<NodeView>& nodes, const SearchClockRates& rates, double from,
                  double reads) {
  for (std::ptrdiff_t i = IntervalOf(nodes, from); reads > 0; ++i) {
    const double rate = RateAfterNode(nodes, rates, i);
    const double end = IntervalEnd(nodes, i);
    const double available = (end - from) * rate;
    if (reads <= available) return from + reads / rate;
    reads -= available;
    from = end;
  }
  return from;
}

}  // namespace waymark::laser_slam
