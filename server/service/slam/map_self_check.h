#ifndef WAYMARK_SERVER_SERVICE_SLAM_MAP_SELF_CHECK_H_
#define WAYMARK_SERVER_SERVICE_SLAM_MAP_SELF_CHECK_H_

// The map's self-check (server/laser_slam/mapping/map_consistency.h) as the API carries it
// (v1::MapSelfCheck in GetMap and, for closed sessions, in the Session that ListSessions shows).

#include <cstddef>

#include "server/laser_slam/mapping/map_consistency.h"
#include "server/service/slam/folder.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// Areas that contradict themselves GetMap lists, worst first: every one of the worst map of
// docs/laser-slam.md (MIT Killian, 68), so that occupancy.png outlines them all, in a few kB.
inline constexpr size_t kMaxMapCheckAreas = 100;
// ... and a Session (ListSessions): enough to say where a map folded.
inline constexpr size_t kMaxSessionCheckAreas = 10;
// Contradicting cells GetMap lists (8 bytes each): a fold is a few thousand cells of 10 cm, and
// 100000 of them keep a map's answer under a megabyte.
inline constexpr size_t kMaxMapCheckCells = 100'000;

// `report` as the API says it, with at most `max_areas` of its areas that contradict themselves
// (worst first) and `max_cells` contradicting cells (0: none, as a Session carries it).
v1::MapSelfCheck ToProtoMapSelfCheck(const laser_slam::MapConsistencyReport& report,
                                     size_t max_areas, size_t max_cells);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_MAP_SELF_CHECK_H_
