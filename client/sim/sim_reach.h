#ifndef WAYMARK_CLIENT_SIM_SIM_REACH_H_
#define WAYMARK_CLIENT_SIM_SIM_REACH_H_

// Where a robot fits in a world and which walls its laser can see from there: the ground truth
// for how complete an exploration can get at all (some wall length is never seen: behind a
// cabinet, or only visible from spots the robot does not fit into), and for the checks of the
// built-in worlds. Plain geometry on a grid, no simulation.

#include <vector>

#include "client/sim/sim_world.h"

namespace waymark::adapters {

// The nodes (x0 + i * cell, y0 + j * cell) of a grid over the world's bounding box plus a 1 m
// margin that a disc of some radius reaches from the start: nodes at least the radius from every
// wall, joined through their 4-neighbours.
struct Reach {
  double x0 = 0, y0 = 0, cell = 0.05;
  int nx = 0, ny = 0;
  std::vector<char> reached;  // nx * ny, node (i, j) at j * nx + i
  bool leaked = false;        // reached the margin: the world is not closed

  // Index into `reached` of the node nearest (x, y); -1 outside the grid.
  long Index(double x, double y) const;
  // Whether the node nearest (x, y) is reached; false outside the grid.
  bool At(double x, double y) const;
};

// Nothing is reached when the start itself is closer than `radius` to a wall. A step between
// neighbours is not checked against the walls: with the cell much smaller than the radius, both
// ends being free is enough.
Reach ReachableSpace(const World& world, double radius, double cell = 0.05);

// A piece of a wall, represented by its middle.
struct WallSample {
  int wall = 0;  // index into World::walls
  double x = 0, y = 0;
  double length = 0;  // of the piece, m
};

// Every wall cut into equal pieces of at most `step` metres, one sample at each piece's middle;
// a zero-length wall gives none.
std::vector<WallSample> SampleWalls(const std::vector<Wall>& walls, double step);

// The summed length of the samples' pieces, m.
double SampleLength(const std::vector<WallSample>& samples);

struct VisibilityOptions {
  double radius = 0.4;        // m: the exploration defaults' robot radius 0.3 + clearance 0.1
  double max_range = 8.0;     // m: the LMS200's (SimOptions::max_range)
  double cell = 0.05;         // m: the reach grid
  double sample_step = 0.05;  // m between wall samples
  int rays = 360;             // directions tried from each sample (1 degree apart)
};

// The wall samples a laser sees from some reachable place: a straight line of at most max_range
// from the sample to a reached node that no wall crosses. The lines tried leave the sample in
// `rays` directions; each needs checking only up to the first reached node it passes (what the
// sample sees is star-shaped round it: a node further on is seen only if that one is).
std::vector<WallSample> VisibleWalls(const World& world, const VisibilityOptions& options = {});

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_SIM_SIM_REACH_H_
