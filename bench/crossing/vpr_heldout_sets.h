#ifndef WAYMARK_BENCH_CROSSING_VPR_HELDOUT_SETS_H_
#define WAYMARK_BENCH_CROSSING_VPR_HELDOUT_SETS_H_

// Unknown-places variants of the evaluation sets (issue 34): each holds out some of a set's places
// from the database (never enrolled) and queries them; every such query must be refused. The
// databases keep as many places as the set allows, so that the global path's chance model
// (server/crossing/global_chance.h) sees a database of the set's usual size.
//
// - corridor: the 111 refs cut into three blocks of 37; fold b enrolls the refs outside block b.
//   A query whose ground truth lies 3 or more frames inside block b is unknown; one whose ground
//   truth lies entirely outside it is known; the rest (at the edges) are left out.
// - triplets: fold (k, pair): image k of the 8 places outside the held-out pair enrolled; the
//   other images of those 8 are known queries, all 3 images of the pair unknown (3 x 5 folds).
// - KITTI / Bonn: one half of the sequence's frames (every `stride`-th) enrolled, the other half's
//   frames queried; a query farther than `min_distance_m` from every enrolled frame is unknown,
//   nearer ones are left out (two folds: first half enrolled, second half enrolled).
// - rotation set: views cut from 360-degree photos (rotation_set.h), 12 headings per place;
//   fold f holds out two places (f, f + 1 mod n): the other places' 12 headings enrolled, the
//   held-out places queried at every sector plus each offset.

#include <string>
#include <vector>

#include "bench/crossing/vpr_datasets.h"
#include "bench/crossing/vpr_experiment.h"

namespace waymark::vpr {

std::vector<Protocol> CorridorHeldOut(const CorridorSet& set, int blocks = 3, int margin = 3);
std::vector<Protocol> TripletHeldOut(const TripletSet& set, int held_out_places = 2);
std::vector<Protocol> SequenceHeldOut(const FrameSequence& seq, int stride, double min_distance_m);

// The rotation set as paths into a FeatureCache: RotationKey names a rendered view.
std::string RotationKey(const std::string& panorama, double heading_deg, double fov_deg);
// Every place's 12 headings enrolled (place = index + 1); queries at 30 k + offset for every
// place, sector and offset, accepted = the place.
Protocol RotationKnown(const std::vector<std::string>& panoramas,
                       const std::vector<double>& offsets, double fov_deg);
std::vector<Protocol> RotationHeldOut(const std::vector<std::string>& panoramas,
                                      const std::vector<double>& offsets, double fov_deg);

}  // namespace waymark::vpr

#endif  // WAYMARK_BENCH_CROSSING_VPR_HELDOUT_SETS_H_
