#ifndef WAYMARK_SERVER_SERVICE_SLAM_EXPLORATION_PARAMS_H_
#define WAYMARK_SERVER_SERVICE_SLAM_EXPLORATION_PARAMS_H_

// Translation between ExplorationConfig / SuggestedControl (slam.proto) and the planner's types
// (server/laser_slam/exploration/exploration_options.h, exploration_types.h).

#include "absl/status/status.h"
#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/exploration/goal_layer.h"
#include "server/service/slam/folder.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// Overrides `options` with the set fields of `config`; INVALID_ARGUMENT naming the field
// ("laser.exploration.max_linear must be in ...") for a value out of range or an unknown mode.
absl::Status ApplyExplorationConfig(const v1::ExplorationConfig& config,
                                    laser_slam::ExplorationOptions* options);

// Every field of `config` set from `options` (the effective config a session reports).
void FillEffectiveExploration(const laser_slam::ExplorationOptions& options,
                              v1::ExplorationConfig* config);

void FillSuggestion(const laser_slam::Suggestion& suggestion, v1::SuggestedControl* control);

void FillExplorationProgress(const laser_slam::GoalProgress& progress,
                             v1::ExplorationProgress* out);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_EXPLORATION_PARAMS_H_
