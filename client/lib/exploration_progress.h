#ifndef WAYMARK_CLIENT_LIB_EXPLORATION_PROGRESS_H_
#define WAYMARK_CLIENT_LIB_EXPLORATION_PROGRESS_H_

// Where a goal-layer exploration stands (SlamUpdate.exploration, docs/exploration.md), as every
// client that drives a robot reads it: the robot loop and the simulated exploration both stop the
// robot at the end, and print and summarise the state by the same names.

#include <string>

#include "waymark/v1/slam.pb.h"

namespace waymark::client {

// DONE or STUCK: the session will suggest nothing but FINISHED (standing still) from here on.
bool ExplorationEnded(const v1::ExplorationProgress& progress);

// "exploring", "done", "stuck"; "-" when the session reports no state (no goal layer: passive,
// wander, or ACTIVE with goal_layer off, or a server older than the field).
std::string ExplorationStateName(const v1::ExplorationProgress& progress);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_EXPLORATION_PROGRESS_H_
