#ifndef WAYMARK_CLIENT_SIM_SIM_WORLD_H_
#define WAYMARK_CLIENT_SIM_SIM_WORLD_H_

// A 2-D world for the robot simulator: walls as line segments and a start pose.
//
// Text format (one statement per line, `#` starts a comment, units metres and radians):
//   name NAME                  optional, for titles
//   start X Y THETA            the robot's start pose (required once)
//   wall X1 Y1 X2 Y2           one wall
//   box X1 Y1 X2 Y2            an axis-aligned obstacle: four walls around the rectangle
//   room NAME X1 Y1 X2 Y2      a room's rectangle, no walls: which rooms a robot entered (several
//                              robots exploring together count the rooms explored twice)
// Errors name the line and what is wrong (INVALID_ARGUMENT); an unreadable file is NOT_FOUND.

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/devices/robot_devices.h"

namespace waymark::adapters {

struct Wall {
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0;
};

struct Room {
  std::string name;
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0;  // x1 < x2, y1 < y2
  bool Contains(double x, double y) const { return x >= x1 && x <= x2 && y >= y1 && y <= y2; }
};

struct World {
  std::string name;
  BasePose start;
  std::vector<Wall> walls;
  std::vector<Room> rooms;  // annotations (room lines); may be empty

  double WallLength() const;  // total, m
};

absl::StatusOr<World> ParseWorld(const std::string& text);
absl::StatusOr<World> LoadWorldFile(const std::string& path);

// Built-in worlds: "corridor" (a long corridor with side rooms and dead ends, like the paper's
// floor), "loop" (a corridor around a block), "office" (a room with desks and cabinets).
std::vector<std::string> BuiltinWorldNames();
// A built-in name, or else a file path. NOT_FOUND lists the built-in names.
absl::StatusOr<World> LoadWorld(const std::string& name_or_path);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_SIM_SIM_WORLD_H_
