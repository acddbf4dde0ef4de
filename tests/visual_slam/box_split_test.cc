#include "server/visual_slam/geometry/box_split.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace waymark::visual_slam {
namespace {

Box MakeBox(float x, float y, float w, float h) {
  Box b;
  b.x = x, b.y = y, b.w = w, b.h = h;
  return b;
}

TEST(InsideAnyBox, InsideEdgeAndOutsideOfOneBox) {
  const std::vector<Box> boxes = {MakeBox(10, 20, 30, 40)};  // x in [10, 40], y in [20, 60]
  const std::vector<cv::Point2f> pixels = {
      {25, 40},     // inside
      {10, 20},     // top-left corner
      {40, 60},     // bottom-right corner
      {40, 35},     // right edge
      {9.9f, 40},   // just left
      {25, 60.1f},  // just below
      {100, 100},   // far outside
  };
  EXPECT_EQ(InsideAnyBox(pixels, boxes),
            (std::vector<bool>{true, true, true, true, false, false, false}));
}

TEST(InsideAnyBox, MultipleBoxesAreAUnion) {
  const std::vector<Box> boxes = {MakeBox(0, 0, 10, 10), MakeBox(50, 50, 10, 10),
                                  MakeBox(5, 5, 10, 10)};
  const std::vector<cv::Point2f> pixels = {{2, 2}, {55, 58}, {14, 14}, {30, 30}, {12, 3}};
  EXPECT_EQ(InsideAnyBox(pixels, boxes), (std::vector<bool>{true, true, true, false, false}));
}

TEST(InsideAnyBox, NoBoxesNoPixelsAndBadValues) {
  const std::vector<cv::Point2f> pixels = {{1, 1}, {2, 2}};
  EXPECT_EQ(InsideAnyBox(pixels, {}), (std::vector<bool>{false, false}));
  EXPECT_TRUE(InsideAnyBox({}, {MakeBox(0, 0, 5, 5)}).empty());
  // A NaN pixel is inside nothing; a box with negative or NaN size contains nothing.
  const float nan = std::nanf("");
  EXPECT_EQ(InsideAnyBox({{nan, 1}, {1, 1}}, {MakeBox(0, 0, 5, 5)}),
            (std::vector<bool>{false, true}));
  EXPECT_EQ(InsideAnyBox({{1, 1}}, {MakeBox(5, 5, -10, -10), MakeBox(0, 0, nan, 5)}),
            (std::vector<bool>{false}));
}

}  // namespace
}  // namespace waymark::visual_slam
