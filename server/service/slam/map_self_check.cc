#include "server/service/slam/map_self_check.h"

#include <algorithm>
#include <vector>

namespace waymark::service {

namespace ls = laser_slam;

namespace {

int EvidenceOf(const ls::ConsistencyTile& tile) {
  return tile.confirmed + tile.contradicted + tile.one_sided + tile.stray;
}

}  // namespace

v1::MapSelfCheck ToProtoMapSelfCheck(const ls::MapConsistencyReport& report, size_t max_areas,
                                     size_t max_cells) {
  v1::MapSelfCheck out;
  out.set_consistent(report.consistent);
  out.set_contradicted_fraction(report.fraction);
  out.set_areas_contradicting(static_cast<uint32_t>(std::max(0, report.tiles_contradicting)));
  out.set_verdict(report.verdict);
  out.set_nodes(static_cast<uint32_t>(std::max(0, report.nodes)));
  out.set_submaps(static_cast<uint32_t>(std::max(0, report.submaps)));
  out.set_resolution(report.resolution);
  out.set_contradicted(static_cast<uint32_t>(std::max(0, report.contradicted)));
  out.set_evidence(static_cast<uint32_t>(
      std::max(0, report.confirmed + report.contradicted + report.one_sided + report.stray)));
  out.set_baseline_fraction(report.baseline_fraction);

  std::vector<const ls::ConsistencyTile*> failing;
  for (const ls::ConsistencyTile& tile : report.tiles) {
    if (tile.contradicts) failing.push_back(&tile);
  }
  // Worst first; among equal fractions the one with more contradicted cells (more wall moved).
  std::sort(failing.begin(), failing.end(), [](const auto* a, const auto* b) {
    if (a->fraction != b->fraction) return a->fraction > b->fraction;
    return a->contradicted > b->contradicted;
  });
  failing.resize(std::min(failing.size(), max_areas));
  for (const ls::ConsistencyTile* tile : failing) {
    v1::MapCheckArea* area = out.add_worst_areas();
    area->set_min_x(tile->min.x());
    area->set_min_y(tile->min.y());
    area->set_size(tile->size);
    area->set_contradicted_fraction(tile->fraction);
    area->set_contradicted(static_cast<uint32_t>(std::max(0, tile->contradicted)));
    area->set_evidence(static_cast<uint32_t>(std::max(0, EvidenceOf(*tile))));
  }

  out.set_contradicting_cell_count(static_cast<uint32_t>(report.contradicting_cells.size()));
  const size_t listed = std::min(report.contradicting_cells.size(), max_cells);
  out.mutable_contradicting_cells()->Reserve(static_cast<int>(2 * listed));
  for (size_t i = 0; i < listed; ++i) {
    out.add_contradicting_cells(static_cast<float>(report.contradicting_cells[i].x()));
    out.add_contradicting_cells(static_cast<float>(report.contradicting_cells[i].y()));
  }
  return out;
}

}  // namespace waymark::service
