#ifndef WAYMARK_CLIENT_EVAL_RELATION_BUILDER_H_
#define WAYMARK_CLIENT_EVAL_RELATION_BUILDER_H_

// Relations (Kummerle et al. 2009, see relations_metric.h) built from a reference trajectory of
// keyframes, e.g. a GMapping-corrected log's poses, for logs that have no published relations.
// Kummerle's own files pair scans close in time (local accuracy) and scans far apart in time that
// see the same place (loops: the drift a loop closure must remove); the builder does the same:
//   - sequential: keyframe i with i + gap for each gap (gap 1: every pair; larger gaps with a
//     stride, so each gap gives about `target_per_gap` relations);
//   - loops: keyframes i < j within loop_radius_m of each other, at least loop_min_keyframes_apart
//     keyframes and loop_min_travel_m of travelled path apart (a revisit, not a pause); one partner
//     per i (the nearest j, the earliest on ties), evenly subsampled to max_loop_relations.
// Deterministic: the same trajectory gives the same relations, in the same order.

#include <string>
#include <vector>

#include "client/datasets/tum_trajectory.h"
#include "client/eval/relations_metric.h"

namespace waymark::cli {

struct RelationBuilderOptions {
  std::vector<int> gaps = {1, 3, 10};
  int target_per_gap = 1000;  // gaps > 1 only; gap 1 keeps every pair
  double loop_radius_m = 2.0;
  int loop_min_keyframes_apart = 20;
  double loop_min_travel_m = 10.0;
  int max_loop_relations = 1000;
};

struct BuiltRelations {
  std::vector<Relation> relations;  // sequential ones first (by gap, then i), then loops (by i)
  int sequential = 0;
  int loops = 0;
  int loop_candidates = 0;  // keyframes with a loop partner, before subsampling
};

// `keyframes` in travel order with distinct stamps (the relations carry them).
BuiltRelations BuildRelations(const std::vector<StampedPose>& keyframes,
                              const RelationBuilderOptions& options = {});

// The `.relations` text: `t1 t2 x y z roll pitch yaw` per relation (z, roll, pitch = 0), stamps
// with microseconds, metres and radians with 6 decimals; `header` lines (if any) first as `#`
// comments.
std::string FormatRelations(const std::vector<Relation>& relations,
                            const std::vector<std::string>& header = {});

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_RELATION_BUILDER_H_
