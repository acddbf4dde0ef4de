// What a robot reaches in a world and which wall length its laser can see from there.
#include "client/sim/sim_reach.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace waymark::adapters {
namespace {

World Parse(const std::string& text) {
  absl::StatusOr<World> world = ParseWorld(text);
  EXPECT_TRUE(world.ok()) << world.status();
  return world.ok() ? *std::move(world) : World{};
}

// A closed 4 m x 3 m room, the robot in the middle.
constexpr char kRoom[] =
    "start 2 1.5 0\n"
    "wall 0 0 4 0\n"
    "wall 4 0 4 3\n"
    "wall 4 3 0 3\n"
    "wall 0 3 0 0\n";

// The summed length of the samples of wall `wall` whose middle lies in x1 < x < x2.
double LengthWithin(const std::vector<WallSample>& samples, int wall, double x1, double x2) {
  double length = 0;
  for (const WallSample& s : samples) {
    if (s.wall == wall && s.x > x1 && s.x < x2) length += s.length;
  }
  return length;
}

TEST(SampleWallsTest, EqualPiecesOfAtMostTheStepThatAddUpToEachWall) {
  const std::vector<WallSample> samples = SampleWalls({{0, 0, 1, 0}, {2, 2, 2, 2}, {0, 1, 0, 0.12}},
                                                      /*step=*/0.05);
  // 20 pieces of the 1 m wall, none of the zero-length one, 18 of the 0.88 m one (0.0489 m each).
  ASSERT_EQ(samples.size(), 38u);
  EXPECT_EQ(samples[0].wall, 0);
  EXPECT_DOUBLE_EQ(samples[0].x, 0.025);
  EXPECT_DOUBLE_EQ(samples[0].length, 0.05);
  EXPECT_EQ(samples[20].wall, 2);
  EXPECT_NEAR(samples[20].y, 1 - 0.88 / 36, 1e-12);
  EXPECT_NEAR(SampleLength(samples), 1.88, 1e-12);
}

TEST(ReachableSpaceTest, AClosedRoomKeepsTheDiscItsRadiusFromTheWalls) {
  const World room = Parse(kRoom);
  // 0.38 m, not 0.4: no node lies just on the edge of what the disc reaches.
  const Reach reach = ReachableSpace(room, 0.38);
  EXPECT_FALSE(reach.leaked);
  EXPECT_TRUE(reach.At(2, 1.5));
  EXPECT_TRUE(reach.At(0.4, 0.4));    // the corner of what the disc reaches
  EXPECT_FALSE(reach.At(0.35, 1.5));  // too close to the west wall
  EXPECT_FALSE(reach.At(5, 1.5));     // outside
  EXPECT_FALSE(reach.At(50, 1.5));    // off the grid
  // Nodes every 5 cm over x 0.4..3.6, y 0.4..2.6: 65 x 45.
  EXPECT_EQ(std::count(reach.reached.begin(), reach.reached.end(), 1), 65 * 45);

  // A gap wider than the disc lets it out, into the margin; a start against a wall reaches nothing.
  const Reach open = ReachableSpace(Parse("start 2 1.5 0\nwall 0 0 4 0\nwall 4 0 4 3\n"
                                          "wall 4 3 0 3\nwall 0 3 0 2\nwall 0 1 0 0\n"),
                                    0.4);
  EXPECT_TRUE(open.leaked);
  const Reach stuck = ReachableSpace(Parse("start 0.2 1.5 0\nwall 0 0 0 3\n"), 0.4);
  EXPECT_EQ(std::count(stuck.reached.begin(), stuck.reached.end(), 1), 0);
}

TEST(VisibleWallsTest, EveryWallOfAClosedRoomIsVisible) {
  const World room = Parse(kRoom);
  const std::vector<WallSample> visible = VisibleWalls(room);
  EXPECT_EQ(visible.size(), SampleWalls(room.walls, 0.05).size());
  EXPECT_NEAR(SampleLength(visible), room.WallLength(), 1e-9);
}

// A cabinet (three walls) flush against the south wall, 1 m wide: the 1 m of wall behind it is
// never seen, everything else is, the cabinet's own sides included.
TEST(VisibleWallsTest, TheWallBehindACabinetIsNotVisible) {
  const World room = Parse(std::string(kRoom) +
                           "wall 1.5 0 1.5 0.5\n"
                           "wall 1.5 0.5 2.5 0.5\n"
                           "wall 2.5 0.5 2.5 0\n");
  const std::vector<WallSample> visible = VisibleWalls(room);
  EXPECT_DOUBLE_EQ(LengthWithin(visible, 0, 1.5, 2.5), 0);
  EXPECT_NEAR(LengthWithin(visible, 0, 0, 1.5), 1.5, 1e-9);
  EXPECT_NEAR(LengthWithin(visible, 0, 2.5, 4), 1.5, 1e-9);
  EXPECT_NEAR(LengthWithin(visible, 4, 0, 4), 0.5, 1e-9);  // the cabinet's sides and front
  EXPECT_NEAR(LengthWithin(visible, 5, 0, 4), 1.0, 1e-9);
  EXPECT_NEAR(LengthWithin(visible, 6, 0, 4), 0.5, 1e-9);
  EXPECT_NEAR(SampleLength(visible), room.WallLength() - 1.0, 1e-9);
}

// A closed closet the robot drives round (1 m from every wall) but cannot enter: its outer faces
// are seen, the wall that divides its inside is not.
TEST(VisibleWallsTest, AWallOnlyVisibleFromWhereTheRobotCannotGoIsNotVisible) {
  World room = Parse(std::string(kRoom) +
                     "box 2 1 3 2\n"
                     "wall 2 1.5 3 1.5\n");
  room.start = {1, 1.5, 0};  // not in the closet
  const std::vector<WallSample> visible = VisibleWalls(room);
  EXPECT_DOUBLE_EQ(LengthWithin(visible, 8, 0, 4), 0);
  EXPECT_NEAR(SampleLength(visible), room.WallLength() - 1.0, 1e-9);
}

// The laser's range limits what is seen. With 0.5 m, and the nearest nodes 0.4 m from the walls
// (x 0.4..3.6, y 0.4..2.6), a corner's end of each wall is out of reach: (0.025, 0) is 0.51 m
// from the nearest point of node (0.4, 0.4)'s cell.
TEST(VisibleWallsTest, NothingBeyondTheRangeIsVisible) {
  const World room = Parse(kRoom);
  VisibilityOptions options;
  options.radius = 0.38;
  options.max_range = 0.5;
  const std::vector<WallSample> visible = VisibleWalls(room, options);
  EXPECT_DOUBLE_EQ(LengthWithin(visible, 0, 0, 0.05), 0);
  EXPECT_DOUBLE_EQ(LengthWithin(visible, 0, 3.95, 4), 0);
  EXPECT_NEAR(LengthWithin(visible, 0, 0.4, 3.6), 3.2, 1e-9);  // facing the nodes
  EXPECT_LE(SampleLength(visible), room.WallLength() - 8 * 0.05 + 1e-9);
  EXPECT_GE(SampleLength(visible), room.WallLength() - 8 * 0.4);
}

}  // namespace
}  // namespace waymark::adapters
