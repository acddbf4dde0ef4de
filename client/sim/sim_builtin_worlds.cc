#include "client/sim/sim_builtin_worlds.h"

#include <string>
#include <vector>

#include "client/sim/sim_world.h"

namespace waymark::adapters {
namespace {

// Walls are thin segments. In every world the start is at least 0.6 m from every wall, every
// space is reachable through openings at least 1.2 m wide, and every wall can be seen from
// somewhere the robot can go (cabinets against a wall are three walls, not a box, so no edge
// hides behind the room's wall).

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
)";

struct Builtin {
  const char* name;
  const char* text;
};

constexpr Builtin kBuiltins[] = {
    {"corridor", kCorridor},
    {"loop", kLoop},
    {"office", kOffice},
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
