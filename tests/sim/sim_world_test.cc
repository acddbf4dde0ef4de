#include "client/sim/sim_world.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <queue>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/sim/sim_geometry.h"
#include "client/sim/sim_reach.h"

namespace waymark::adapters {
namespace {

using ::testing::HasSubstr;

std::string ParseError(const std::string& text) {
  absl::StatusOr<World> world = ParseWorld(text);
  EXPECT_FALSE(world.ok()) << text;
  if (world.ok()) return "";
  EXPECT_EQ(world.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(world.status().message());
}

TEST(ParseWorldTest, ReadsStatementsCommentsAndBlankLines) {
  absl::StatusOr<World> world = ParseWorld(
      "# a test world\n"
      "\n"
      "name two rooms   # trailing comment\n"
      "start 1 2 0.5\n"
      "wall 0 0 3 4\r\n"
      "  box 10 10 8 9\n");
  ASSERT_TRUE(world.ok()) << world.status();
  EXPECT_EQ(world->name, "two rooms");
  EXPECT_DOUBLE_EQ(world->start.x, 1);
  EXPECT_DOUBLE_EQ(world->start.y, 2);
  EXPECT_DOUBLE_EQ(world->start.theta, 0.5);
  ASSERT_EQ(world->walls.size(), 5u);
  EXPECT_DOUBLE_EQ(world->walls[0].x2, 3);
  EXPECT_DOUBLE_EQ(world->walls[0].y2, 4);
  // wall 5 m + box 2 x 1 m.
  EXPECT_DOUBLE_EQ(world->WallLength(), 5 + 2 * (2 + 1));
  for (size_t i = 1; i < 5; ++i) {
    const Wall& w = world->walls[i];
    EXPECT_TRUE(w.x1 == w.x2 || w.y1 == w.y2);
    EXPECT_GE(std::min(w.x1, w.x2), 8);
    EXPECT_LE(std::max(w.y1, w.y2), 10);
  }
}

TEST(ParseWorldTest, ErrorsNameTheLineAndTheProblem) {
  EXPECT_THAT(ParseError("start 0 0 0\n\nwindow 1 2 3 4\n"), HasSubstr("line 3"));
  EXPECT_THAT(ParseError("start 0 0 0\n\nwindow 1 2 3 4\n"), HasSubstr("unknown keyword 'window'"));
  EXPECT_THAT(ParseError("start 0 0 0\nwall 1 2 3\n"), HasSubstr("line 2: 'wall' takes 4 numbers"));
  EXPECT_THAT(ParseError("start 0 0 0\nwall 1 2 3\n"), HasSubstr("got 3"));
  EXPECT_THAT(ParseError("start 0 0\n"), HasSubstr("line 1: 'start' takes 3 numbers"));
  EXPECT_THAT(ParseError("start 0 0 0\nbox 1 2 3 4 5\n"), HasSubstr("line 2"));
  EXPECT_THAT(ParseError("start 0 0 0\nwall 1 x 3 4\n"), HasSubstr("line 2: 'x' is not a number"));
  EXPECT_THAT(ParseError("start 0 0 0\n#\nwall 1 inf 3 4\n"),
              HasSubstr("line 3: 'inf' is not a finite number"));
  EXPECT_THAT(ParseError("start 0 nan 0\n"), HasSubstr("line 1: 'nan' is not a finite number"));
  EXPECT_THAT(ParseError("start 0 0 0\nwall 1 2 3 4\nwall 1 1 1 1\n"),
              HasSubstr("line 3: zero-length wall"));
  EXPECT_THAT(ParseError("start 0 0 0\nbox 1 1 1 4\n"), HasSubstr("line 2: box with zero width"));
  EXPECT_THAT(ParseError("wall 0 0 1 1\n"), HasSubstr("no start pose"));
  EXPECT_THAT(ParseError(""), HasSubstr("no start pose"));
  EXPECT_THAT(ParseError("start 0 0 0\nwall 0 0 1 1\nstart 1 1 1\n"),
              HasSubstr("line 3: duplicate 'start' (first on line 1)"));
  EXPECT_THAT(ParseError("start 0 0 0\nname\n"), HasSubstr("line 2: 'name' needs a name"));
}

TEST(LoadWorldTest, FilesBuiltinsAndNotFound) {
  const std::string path = testing::TempDir() + "/sim_world_test.world";
  {
    std::ofstream file(path);
    file << "name file world\nstart 0 0 0\nwall 0 1 2 1\nwall 0 -1 2 -1\n";
  }
  absl::StatusOr<World> from_file = LoadWorld(path);
  ASSERT_TRUE(from_file.ok()) << from_file.status();
  EXPECT_EQ(from_file->name, "file world");
  EXPECT_DOUBLE_EQ(from_file->WallLength(), 4);

  {
    std::ofstream file(path);
    file << "start 0 0 0\nwal 0 1 2 1\n";
  }
  absl::StatusOr<World> bad = LoadWorldFile(path);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr(path + ": line 2: unknown keyword 'wal'"));
  std::remove(path.c_str());

  EXPECT_EQ(LoadWorldFile(path).status().code(), absl::StatusCode::kNotFound);
  absl::StatusOr<World> missing = LoadWorld("no-such-world");
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.status().message(), HasSubstr("no-such-world"));
  EXPECT_THAT(missing.status().message(), HasSubstr("corridor, loop, office"));
}

// The disc the reachability checks flood with, per world: nearly 0.6 m radius where every opening
// is at least 1.2 m wide, 0.45 m in `cluttered`, whose doorways are 1.0-1.1 m wide on purpose.
double FloodRadius(const std::string& world) { return world == "cluttered" ? 0.45 : 0.55; }

TEST(BuiltinWorldsTest, ParseWithStartInFreeSpace) {
  ASSERT_EQ(BuiltinWorldNames(),
            (std::vector<std::string>{"corridor", "loop", "office", "building", "cluttered"}));
  for (const std::string& name : BuiltinWorldNames()) {
    SCOPED_TRACE(name);
    absl::StatusOr<World> world = LoadWorld(name);
    ASSERT_TRUE(world.ok()) << world.status();
    EXPECT_EQ(world->name, name);
    EXPECT_GT(world->WallLength(), 0);
    EXPECT_GE(world->walls.size(), 10u);
    EXPECT_GE(geometry::Clearance(world->walls, world->start.x, world->start.y), 0.6);
  }
}

// Every space is reachable through the world's openings (a disc of FloodRadius gets through), the
// world is closed, and every wall can be seen from somewhere reachable.
TEST(BuiltinWorldsTest, ClosedAndEveryWallVisibleFromReachableSpace) {
  for (const std::string& name : BuiltinWorldNames()) {
    SCOPED_TRACE(name);
    absl::StatusOr<World> world = LoadWorld(name);
    ASSERT_TRUE(world.ok()) << world.status();
    const Reach reach = ReachableSpace(*world, FloodRadius(name));
    EXPECT_FALSE(reach.leaked);
    ASSERT_GT(std::count(reach.reached.begin(), reach.reached.end(), 1), 1600);  // 4 m^2
    VisibilityOptions options;
    options.radius = FloodRadius(name);
    std::vector<bool> seen(world->walls.size(), false);
    for (const WallSample& s : VisibleWalls(*world, options)) seen[s.wall] = true;
    for (size_t k = 0; k < world->walls.size(); ++k) {
      const Wall& w = world->walls[k];
      EXPECT_TRUE(seen[k]) << "wall " << k << ": " << w.x1 << " " << w.y1 << " " << w.x2 << " "
                           << w.y2;
    }
  }
}

// The obstacles reachable space closes round: the unreached (4-connected) regions that do not
// touch the grid's margin, each measured by the shorter side of its bounding box in metres. A
// corridor loop closes round a block of rooms; a desk the robot drives round is a small one. A room
// it cannot enter is not one: its walls join the rest of the walls it stands among.
std::vector<double> EnclosedSizes(const Reach& reach) {
  std::vector<char> seen = reach.reached;
  std::vector<double> sizes;
  for (int first = 0; first < reach.nx * reach.ny; ++first) {
    if (seen[first]) continue;
    seen[first] = 1;
    int imin = first % reach.nx, imax = imin, jmin = first / reach.nx, jmax = jmin;
    bool margin = false;
    std::queue<int> queue;
    queue.push(first);
    while (!queue.empty()) {
      const int i = queue.front() % reach.nx, j = queue.front() / reach.nx;
      queue.pop();
      imin = std::min(imin, i), imax = std::max(imax, i);
      jmin = std::min(jmin, j), jmax = std::max(jmax, j);
      if (i == 0 || j == 0 || i == reach.nx - 1 || j == reach.ny - 1) {
        margin = true;
        continue;
      }
      for (const int next : {j * reach.nx + i + 1, j * reach.nx + i - 1, (j + 1) * reach.nx + i,
                             (j - 1) * reach.nx + i}) {
        if (seen[next]) continue;
        seen[next] = 1;
        queue.push(next);
      }
    }
    if (!margin) sizes.push_back(reach.cell * (std::min(imax - imin, jmax - jmin) + 1));
  }
  return sizes;
}

// How many blocks at least 5 m across the robot can drive all the way round (the flood disc of
// FloodRadius): the corridor loops.
int CorridorLoops(const std::string& name) {
  absl::StatusOr<World> world = LoadWorld(name);
  EXPECT_TRUE(world.ok()) << world.status();
  if (!world.ok()) return -1;
  const std::vector<double> sizes = EnclosedSizes(ReachableSpace(*world, FloodRadius(name)));
  return static_cast<int>(
      std::count_if(sizes.begin(), sizes.end(), [](double s) { return s >= 5; }));
}

// `building` is at least 40 m x 30 m and its corridor runs round its block of rooms. The other
// worlds are the check's controls: `loop` has its one block, `corridor` and `office` none.
TEST(BuiltinWorldsTest, BuildingIsLargeWithCorridorLoops) {
  absl::StatusOr<World> world = LoadWorld("building");
  ASSERT_TRUE(world.ok()) << world.status();
  double xmin = world->walls[0].x1, xmax = xmin, ymin = world->walls[0].y1, ymax = ymin;
  for (const Wall& w : world->walls) {
    xmin = std::min({xmin, w.x1, w.x2});
    xmax = std::max({xmax, w.x1, w.x2});
    ymin = std::min({ymin, w.y1, w.y2});
    ymax = std::max({ymax, w.y1, w.y2});
  }
  EXPECT_GE(xmax - xmin, 40);
  EXPECT_GE(ymax - ymin, 30);
  EXPECT_EQ(CorridorLoops("building"), 1);
  EXPECT_EQ(CorridorLoops("loop"), 1);
  EXPECT_EQ(CorridorLoops("corridor"), 0);
  EXPECT_EQ(CorridorLoops("office"), 0);
}

// The area (m^2) that the 0.45 m flood disc reaches, that has room for a 0.55 m disc, and that the
// 0.55 m disc still does not reach from the start: space behind openings narrower than 1.2 m.
double BehindNarrowOpenings(const std::string& name) {
  absl::StatusOr<World> world = LoadWorld(name);
  EXPECT_TRUE(world.ok()) << world.status();
  if (!world.ok()) return -1;
  const Reach small = ReachableSpace(*world, 0.45), large = ReachableSpace(*world, 0.55);
  int cells = 0;
  for (int j = 0; j < small.ny; ++j) {
    for (int i = 0; i < small.nx; ++i) {
      const int k = j * small.nx + i;
      if (!small.reached[k] || large.reached[k]) continue;
      const double x = small.x0 + i * small.cell, y = small.y0 + j * small.cell;
      cells += geometry::Clearance(world->walls, x, y) >= 0.55;
    }
  }
  return cells * small.cell * small.cell;
}

// `cluttered`'s doorways are narrower than 1.2 m: whole rooms lie behind them. In the other worlds
// nothing does (their openings are at least 1.2 m wide, which FloodRadius relies on).
TEST(BuiltinWorldsTest, OnlyClutteredHasNarrowDoorways) {
  EXPECT_GT(BehindNarrowOpenings("cluttered"), 20);
  for (const char* name : {"corridor", "loop", "office", "building"}) {
    EXPECT_EQ(BehindNarrowOpenings(name), 0) << name;
  }
}

}  // namespace
}  // namespace waymark::adapters

namespace waymark::adapters {
namespace {

// `room` lines annotate rooms (several robots count the rooms explored twice): no walls.
TEST(ParseWorldTest, RoomsAreAnnotationsNotWalls) {
  auto world = ParseWorld("start 1 1 0\nwall 0 0 4 0\nroom kitchen 4 3 0 0   # corners either way\n");
  ASSERT_TRUE(world.ok()) << world.status();
  EXPECT_EQ(world->walls.size(), 1u);
  ASSERT_EQ(world->rooms.size(), 1u);
  EXPECT_EQ(world->rooms[0].name, "kitchen");
  EXPECT_TRUE(world->rooms[0].Contains(1, 1));
  EXPECT_FALSE(world->rooms[0].Contains(5, 1));
  EXPECT_THAT(ParseWorld("start 0 0 0\nroom a 0 0 1\n").status().message(),
              HasSubstr("line 2: 'room' takes a name and 4 numbers"));
  EXPECT_THAT(ParseWorld("start 0 0 0\nroom a 0 0 0 1\n").status().message(),
              HasSubstr("line 2: room with zero width"));
  auto building = LoadWorld("building");
  auto office = LoadWorld("office");
  ASSERT_TRUE(building.ok() && office.ok());
  EXPECT_EQ(building->rooms.size(), 12u);
  EXPECT_EQ(office->rooms.size(), 3u);
}

}  // namespace
}  // namespace waymark::adapters
