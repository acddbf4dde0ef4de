#include "client/sim/sim_builtin_worlds.h"

#include <string>
#include <vector>

#include "client/sim/sim_world.h"

namespace waymark::adapters {
namespace {

// Walls are thin segments. In every world the start is at least 0.6 m from every wall, every
// space is reachable through openings at least 1.2 m wide (in `cluttered` 1.0 m: its narrow
// doorways are the point of it), and every wall can be seen from somewhere the robot can go
// (cabinets against a wall are three walls, not a box, so no edge hides behind the room's wall;
// no box stands flush against a wall).

constexpr char kCorridor[] = R"(# corridor: a building floor like the paper's. A closed corridor 30 m x 2 m
# (x 0..30, y 0..2) with four 4 x 4 m side rooms through 1.4 m doorways, two on each side, and a
# dead-end side corridor 1.8 m wide and 5 m deep. Start near the west end, facing east.
name corridor
start 1.5 1.0 0

# Corridor: closed ends; its north and south walls broken by the doorways.
wall 0 0 0 2
wall 30 0 30 2
wall 0 2 5.3 2
wall 6.7 2 13 2
wall 14.8 2 19.3 2
wall 20.7 2 30 2
wall 0 0 11.3 0
wall 12.7 0 25.3 0
wall 26.7 0 30 0

# North room A (x 4..8, y 2..6), doorway x 5.3..6.7.
wall 4 2 4 6
wall 4 6 8 6
wall 8 6 8 2

# Dead-end side corridor (x 13..14.8, y 2..7).
wall 13 2 13 7
wall 13 7 14.8 7
wall 14.8 7 14.8 2

# North room C (x 18..22, y 2..6), doorway x 19.3..20.7; a cabinet in its north-east corner.
wall 18 2 18 6
wall 18 6 22 6
wall 22 6 22 2
wall 21.5 6 21.5 5.2
wall 21.5 5.2 22 5.2

# South room B (x 10..14, y -4..0), doorway x 11.3..12.7.
wall 10 0 10 -4
wall 10 -4 14 -4
wall 14 -4 14 0

# South room D (x 24..28, y -4..0), doorway x 25.3..26.7; a desk in it.
wall 24 0 24 -4
wall 24 -4 28 -4
wall 28 -4 28 0
box 25.2 -2.8 26.8 -2.0
)";

constexpr char kLoop[] = R"(# loop: a corridor around a rectangular block. Outer walls 16 m x 10 m (x 0..16, y 0..10),
# block 12 m x 6 m (x 2..14, y 2..8): a corridor 2 m wide all round, with two cabinets and an
# alcove so that its sides do not all look alike. Start in the south corridor, facing east.
name loop
start 4 1 0

# Outer walls; the west wall opens into an alcove 1.2 m wide and 1 m deep (y 4..5.2).
wall 0 0 16 0
wall 16 0 16 10
wall 16 10 0 10
wall 0 10 0 5.2
wall 0 4 0 0
wall 0 5.2 -1 5.2
wall -1 5.2 -1 4
wall -1 4 0 4

# The block.
box 2 2 14 8

# Cabinets against the outer walls (0.45 m deep: the corridor keeps 1.55 m).
wall 5 10 5 9.55
wall 5 9.55 6.2 9.55
wall 6.2 9.55 6.2 10
wall 10 0 10 0.4
wall 10 0.4 11.5 0.4
wall 11.5 0.4 11.5 0
)";

constexpr char kOffice[] = R"(# office: one 12 m x 9 m room (x 0..12, y 0..9) with five desks (1.6 x 0.8 m), a pillar and
# cabinets against the walls, and a 3 m x 3.5 m side room (x 12..15, y 5.5..9) through a 1.4 m
# doorway in the east wall. Passages are at least 1.2 m wide. Start in the south-west corner,
# facing east.
name office
start 1 1 0

# Room walls; the east wall has the doorway at y 6.5..7.9.
wall 0 0 12 0
wall 12 0 12 6.5
wall 12 7.9 12 9
wall 12 9 0 9
wall 0 9 0 0

# Side room.
wall 12 5.5 15 5.5
wall 15 5.5 15 9
wall 15 9 12 9

# Desks and a pillar.
box 2 2 3.6 2.8
box 2 5.5 3.6 6.3
box 6 2 7.6 2.8
box 6 5.5 7.6 6.3
box 9.5 4 10.3 5.6
box 4.6 4 5 4.4

# Cabinets against the main room's walls (three walls each).
wall 0 7 0.5 7
wall 0.5 7 0.5 8.2
wall 0.5 8.2 0 8.2
wall 9 9 9 8.5
wall 9 8.5 10.6 8.5
wall 10.6 8.5 10.6 9
wall 9 0 9 0.5
wall 9 0.5 11 0.5
wall 11 0.5 11 0
wall 12 2 11.5 2
wall 11.5 2 11.5 3.2
wall 11.5 3.2 12 3.2
# A cabinet in the side room's south-east corner (two walls: the room's walls are its back).
wall 14.5 5.5 14.5 6.5
wall 14.5 6.5 15 6.5

# Rooms (annotations, no walls): the main room split at x = 6 into its west half, where the
# robots start, and its east half, and the side room.
room west 0 0 6 9
room east 6 0 12 9
room side 12 5.5 15 9
)";

constexpr char kBuilding[] = R"(# building: a floor 40 m x 30 m (x 0..40, y 0..30), for explorers that only look nearby. A
# corridor ring 2 m wide (centre line 24 m x 14 m, 76 m round) encloses a block of four rooms
# (11 m x 6 m); three rooms (8-10 m x 7 m) open off its south side, three off its north side, and
# a wing room (7 m x 12 m) off each end: twelve rooms, all through doorways 1.3 m wide. From the
# corridor only a strip of a room shows through its doorway; the walls beside the doorway show
# from the doorway itself. Sized so that a robot at the paper's 0.15 m/s can drive the ring and
# look into every room within 1800 s. Start in the south corridor near the west end, facing east.
name building
start 10 8 0

# Corridor ring: outer walls (doorways to the south and north rooms and the wings), inner
# walls (doorways to the block's rooms).
wall 7 7 10.35 7
wall 11.65 7 19.35 7
wall 20.65 7 28.35 7
wall 29.65 7 33 7
wall 7 23 10.35 23
wall 11.65 23 19.35 23
wall 20.65 23 28.35 23
wall 29.65 23 33 23
wall 7 7 7 14.35
wall 7 15.65 7 23
wall 33 7 33 14.35
wall 33 15.65 33 23
wall 9 9 13.35 9
wall 14.65 9 24.35 9
wall 25.65 9 31 9
wall 9 21 13.35 21
wall 14.65 21 24.35 21
wall 25.65 21 31 21
wall 9 9 9 21
wall 31 9 31 21

# The block's four rooms (11 m x 6 m): two along the south corridor, two along the north one.
wall 9 15 31 15
wall 20 9 20 21

# South rooms (y 0..7) and north rooms (y 23..30), three each.
wall 7 0 33 0
wall 7 0 7 7
wall 33 0 33 7
wall 15 0 15 7
wall 25 0 25 7
wall 7 30 33 30
wall 7 23 7 30
wall 33 23 33 30
wall 15 23 15 30
wall 25 23 25 30

# Wing rooms at the ends (x 0..7 and x 33..40, y 9..21).
wall 0 9 7 9
wall 0 21 7 21
wall 0 9 0 21
wall 33 9 40 9
wall 33 21 40 21
wall 40 9 40 21

# Furniture: a desk, a table, a corner cabinet (three walls), a crate.
box 17 2 19 3
box 23.5 17.5 26.5 19
wall 32.5 30 32.5 29.2
wall 32.5 29.2 33 29.2
box 35.5 14 37.5 15

# Rooms (annotations, no walls): the twelve rooms; the corridor ring is not one.
room south-west 7 0 15 7
room south 15 0 25 7
room south-east 25 0 33 7
room north-west 7 23 15 30
room north 15 23 25 30
room north-east 25 23 33 30
room block-south-west 9 9 20 15
room block-south-east 20 9 31 15
room block-north-west 9 15 20 21
room block-north-east 20 15 31 21
room wing-west 0 9 7 21
room wing-east 33 9 40 21
)";

constexpr char kCluttered[] = R"(# cluttered: a 20 m x 15 m floor (x 0..20, y 0..15) full of furniture, with narrow doorways
# (1.0-1.1 m: the planner's robot, 0.6 m across with 0.1 m clearance each side, only just fits
# through; the simulated body is 0.5 m across). An open-plan office (x 0..12, y 0..9) with six
# desks, a pillar, a printer and cabinets; a meeting room (x 0..6, y 9..15) and a kitchen
# (x 6..12, y 9..15) north of it, joined to each other and to the office; a lab (x 12..20,
# y 0..7) with two benches and a pillar; a store (x 12..20, y 7..15) with four rows of shelves and
# 1.1 m aisles, reached from the lab and the kitchen. Passages between the furniture are at least
# 1.0 m wide. Start among the office's desks, facing east.
name cluttered
start 3.8 3.15 0

# Outer walls.
wall 0 0 20 0
wall 20 0 20 15
wall 20 15 0 15
wall 0 15 0 0

# Inner walls and their doorways: office-meeting room x 2..3 (1.0 m), office-kitchen
# x 9.5..10.55, meeting room-kitchen y 12.5..13.5 (1.0 m), office-lab y 3..4.1 (1.1 m),
# kitchen-store y 11..12.05, lab-store x 16.5..17.55.
wall 0 9 2 9
wall 3 9 9.5 9
wall 10.55 9 12 9
wall 6 9 6 12.5
wall 6 13.5 6 15
wall 12 0 12 3
wall 12 4.1 12 11
wall 12 12.05 12 15
wall 12 7 16.5 7
wall 17.55 7 20 7

# Office: desks (1.6 x 0.8 m), a pillar, a printer.
box 1.5 1.5 3.1 2.3
box 1.5 4 3.1 4.8
box 4.5 1.5 6.1 2.3
box 4.5 4 6.1 4.8
box 9.2 1.2 10 2.8
box 9.2 5 10 6.6
box 7.6 3 8 3.4
box 4.2 7.2 5 7.8
# Cabinets against the office's south and west walls (three walls each).
wall 6.8 0 6.8 0.45
wall 6.8 0.45 8 0.45
wall 8 0.45 8 0
wall 0 6.2 0.45 6.2
wall 0.45 6.2 0.45 7.4
wall 0.45 7.4 0 7.4

# Meeting room: a table, a cabinet in the north-west corner (two walls).
box 1.8 11.2 4.2 12.8
wall 0 14.4 0.6 14.4
wall 0.6 14.4 0.6 15

# Kitchen: a counter along the north wall (three walls), a table.
wall 7.5 15 7.5 14.4
wall 7.5 14.4 10.5 14.4
wall 10.5 14.4 10.5 15
box 8.3 11 9.5 12.2

# Lab: two benches, a pillar 1 m from the east wall.
box 13.5 1.4 17 2.2
box 13.5 4.2 17 5
box 18.6 3 19 3.4

# Store: shelves (5.4 x 0.5 m) with 1.1 m aisles between them, 1.3 m free at both ends.
box 13.3 8.3 18.7 8.8
box 13.3 9.9 18.7 10.4
box 13.3 11.5 18.7 12
box 13.3 13.1 18.7 13.6
)";

struct Builtin {
  const char* name;
  const char* text;
};

constexpr Builtin kBuiltins[] = {
    {"corridor", kCorridor},
    {"loop", kLoop},
    {"office", kOffice},
    {"building", kBuilding},
    {"cluttered", kCluttered},
};

}  // namespace

const char* BuiltinWorldText(absl::string_view name) {
  for (const Builtin& builtin : kBuiltins) {
    if (name == builtin.name) return builtin.text;
  }
  return nullptr;
}

std::vector<std::string> BuiltinWorldNames() {
  std::vector<std::string> names;
  for (const Builtin& builtin : kBuiltins) names.emplace_back(builtin.name);
  return names;
}

}  // namespace waymark::adapters
