#include "client/sim/sim_world.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "client/sim/sim_builtin_worlds.h"

namespace waymark::adapters {
namespace {

// The number of numbers each statement takes, or -1 for an unknown keyword.
int ArgumentCount(absl::string_view keyword) {
  if (keyword == "start") return 3;
  if (keyword == "wall" || keyword == "box") return 4;
  return -1;
}

absl::string_view ArgumentNames(absl::string_view keyword) {
  return keyword == "start" ? "X Y THETA" : "X1 Y1 X2 Y2";
}

}  // namespace

double World::WallLength() const {
  double total = 0;
  for (const Wall& wall : walls) total += std::hypot(wall.x2 - wall.x1, wall.y2 - wall.y1);
  return total;
}

absl::StatusOr<World> ParseWorld(const std::string& text) {
  World world;
  int start_line = 0;
  int name_line = 0;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    if (const size_t hash = line.find('#'); hash != absl::string_view::npos) {
      line = line.substr(0, hash);
    }
    const std::vector<absl::string_view> tokens =
        absl::StrSplit(line, absl::ByAnyChar(" \t\r\f\v"), absl::SkipEmpty());
    if (tokens.empty()) continue;
    const auto error = [line_number](auto&&... parts) {
      return absl::InvalidArgumentError(absl::StrCat("line ", line_number, ": ", parts...));
    };
    const absl::string_view keyword = tokens[0];

    if (keyword == "name") {
      if (tokens.size() < 2) return error("'name' needs a name");
      if (name_line != 0) return error("duplicate 'name' (first on line ", name_line, ")");
      name_line = line_number;
      world.name = absl::StrJoin(tokens.begin() + 1, tokens.end(), " ");
      continue;
    }
    if (keyword == "room") {  // a name, then a rectangle: not a wall, an annotation
      if (tokens.size() != 6) return error("'room' takes a name and 4 numbers (NAME X1 Y1 X2 Y2)");
      double r[4];
      for (int i = 0; i < 4; ++i) {
        if (!absl::SimpleAtod(tokens[i + 2], &r[i]) || !std::isfinite(r[i])) {
          return error("'", tokens[i + 2], "' is not a finite number");
        }
      }
      if (r[0] == r[2] || r[1] == r[3]) return error("room with zero width or height");
      world.rooms.push_back(Room{std::string(tokens[1]), std::min(r[0], r[2]),
                                 std::min(r[1], r[3]), std::max(r[0], r[2]),
                                 std::max(r[1], r[3])});
      continue;
    }
    const int count = ArgumentCount(keyword);
    if (count < 0) {
      return error("unknown keyword '", keyword, "' (expected name, start, wall, box or room)");
    }
    if (static_cast<int>(tokens.size()) - 1 != count) {
      return error("'", keyword, "' takes ", count, " numbers (", ArgumentNames(keyword),
                   "), got ", tokens.size() - 1);
    }
    double v[4] = {0, 0, 0, 0};
    for (int i = 0; i < count; ++i) {
      if (!absl::SimpleAtod(tokens[i + 1], &v[i])) {
        return error("'", tokens[i + 1], "' is not a number");
      }
      if (!std::isfinite(v[i])) return error("'", tokens[i + 1], "' is not a finite number");
    }

    if (keyword == "start") {
      if (start_line != 0) return error("duplicate 'start' (first on line ", start_line, ")");
      start_line = line_number;
      world.start = BasePose{v[0], v[1], v[2]};
    } else if (keyword == "wall") {
      if (v[0] == v[2] && v[1] == v[3]) return error("zero-length wall");
      world.walls.push_back(Wall{v[0], v[1], v[2], v[3]});
    } else {  // box
      if (v[0] == v[2] || v[1] == v[3]) return error("box with zero width or height");
      const double x1 = std::min(v[0], v[2]), x2 = std::max(v[0], v[2]);
      const double y1 = std::min(v[1], v[3]), y2 = std::max(v[1], v[3]);
      world.walls.push_back(Wall{x1, y1, x2, y1});
      world.walls.push_back(Wall{x2, y1, x2, y2});
      world.walls.push_back(Wall{x2, y2, x1, y2});
      world.walls.push_back(Wall{x1, y2, x1, y1});
    }
  }
  if (start_line == 0) {
    return absl::InvalidArgumentError("no start pose: a world needs one 'start X Y THETA' line");
  }
  return world;
}

absl::StatusOr<World> LoadWorldFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return absl::NotFoundError(absl::StrCat("cannot read world file ", path));
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) return absl::NotFoundError(absl::StrCat("cannot read world file ", path));
  absl::StatusOr<World> world = ParseWorld(text.str());
  if (!world.ok()) {
    return absl::Status(world.status().code(), absl::StrCat(path, ": ", world.status().message()));
  }
  return world;
}

absl::StatusOr<World> LoadWorld(const std::string& name_or_path) {
  if (const char* text = BuiltinWorldText(name_or_path)) {
    absl::StatusOr<World> world = ParseWorld(text);
    if (!world.ok()) {
      return absl::InternalError(absl::StrCat("built-in world ", name_or_path, ": ",
                                              world.status().message()));
    }
    return world;
  }
  std::error_code ignored;
  if (!std::filesystem::is_regular_file(name_or_path, ignored)) {
    return absl::NotFoundError(absl::StrCat("no built-in world or world file named '",
                                            name_or_path, "' (built-in worlds: ",
                                            absl::StrJoin(BuiltinWorldNames(), ", "), ")"));
  }
  return LoadWorldFile(name_or_path);
}

}  // namespace waymark::adapters
