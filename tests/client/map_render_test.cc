// Map pictures: the SVG holds one element per segment and the PNG decodes, from one layout.
#include "client/render/map_render.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "client/render/slam_output.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using testing::ScopedTempDir;

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

MapScene Square() {
  MapScene scene;
  scene.title = "square room";
  scene.segments = {{{0, 0}, {4, 0}, true, true},
                    {{4, 0}, {4, 3}, true, false},
                    {{4, 3}, {0, 3}, false, false},
                    {{0, 3}, {0, 0}, false, true},
                    {{1, 1}, {2, 1}, true, true}};
  ScenePolyline path;
  path.points = {{0.5, 0.5}, {3.5, 0.5}, {3.5, 2.5}};
  path.color = {0, 150, 0};
  path.label = "trajectory";
  scene.polylines.push_back(path);
  ScenePolyline reference = path;
  reference.points = {{0.6, 0.5}, {3.4, 0.7}};
  reference.label = "odometry";
  scene.references.push_back(reference);
  return scene;
}

TEST(MapRender, SvgHasOneElementPerSegmentByClass) {
  const std::string svg = RenderSvg(Square());
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_EQ(Count(svg, "class=\"segment "), 5);
  EXPECT_EQ(Count(svg, "class=\"segment both-real\""), 2);
  EXPECT_EQ(Count(svg, "class=\"segment one-real\""), 2);
  EXPECT_EQ(Count(svg, "class=\"segment both-virtual\""), 1);
  // Endpoints: 10 on the map plus the legend's 6 samples; real filled, virtual hollow.
  EXPECT_EQ(Count(svg, "class=\"endpoint real\""), 6 + 3);
  EXPECT_EQ(Count(svg, "class=\"endpoint virtual\""), 4 + 3);
  EXPECT_EQ(Count(svg, "class=\"trajectory\""), 1);
  EXPECT_EQ(Count(svg, "class=\"reference\""), 1);
  EXPECT_GE(Count(svg, "class=\"scale-bar\""), 1);
  EXPECT_NE(svg.find("square room"), std::string::npos);
  EXPECT_NE(svg.find(" m</text>"), std::string::npos);
  EXPECT_NE(svg.find("both endpoints real"), std::string::npos);
}

TEST(MapRender, YPointsUpAndBothBackEndsShareTheLayout) {
  const Drawing drawing = LayoutScene(Square());
  // The first segment lies on y = 0, the third on y = 3: higher in the world = smaller row.
  std::vector<const DrawItem*> segments;
  for (const DrawItem& item : drawing.items) {
    if (item.css_class.rfind("segment", 0) == 0) segments.push_back(&item);
  }
  ASSERT_EQ(segments.size(), 5u);
  EXPECT_GT(segments[0]->points[0].y, segments[2]->points[0].y);
  EXPECT_NEAR(segments[0]->points[1].x - segments[0]->points[0].x,
              4 * drawing.pixels_per_metre, 1e-6);
  const cv::Mat image = DrawingToImage(drawing);
  EXPECT_EQ(image.cols, drawing.width);
  EXPECT_EQ(image.rows, drawing.height);
  // The middle of the first segment is drawn in its class colour (blue, BGR), off white.
  const Vec2 mid{0.5 * (segments[0]->points[0].x + segments[0]->points[1].x),
                 segments[0]->points[0].y};
  const cv::Vec3b pixel = image.at<cv::Vec3b>(static_cast<int>(mid.y), static_cast<int>(mid.x));
  EXPECT_GT(pixel[0], pixel[2]);
  EXPECT_EQ(image.at<cv::Vec3b>(1, image.cols - 2), cv::Vec3b(255, 255, 255));
}

TEST(MapRender, WritesSvgAndAPngThatDecodes) {
  ScopedTempDir dir;
  ASSERT_TRUE(WriteMapPictures(Square(), dir.path() / "map.svg", dir.path() / "map.png").ok());
  const cv::Mat png = cv::imread((dir.path() / "map.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(png.empty());
  EXPECT_GT(png.cols, 400);
  EXPECT_EQ(Count(testing::ReadAll(dir.path() / "map.svg"), "class=\"segment "), 5);
}

TEST(MapRender, EmptySceneStillRenders) {
  MapScene empty;
  EXPECT_EQ(Count(RenderSvg(empty), "class=\"segment "), 0);
  EXPECT_FALSE(RenderImage(empty).empty());
}

TEST(MapRender, NiceScaleBarLengths) {
  EXPECT_DOUBLE_EQ(NiceLength(0.9), 1);
  EXPECT_DOUBLE_EQ(NiceLength(3.2), 2);
  EXPECT_DOUBLE_EQ(NiceLength(4.0), 5);
  EXPECT_DOUBLE_EQ(NiceLength(8.0), 10);
  EXPECT_DOUBLE_EQ(NiceLength(17), 20);
}

TEST(SlamOutput, SegmentEndpointsFromTheFrame) {
  v1::MapSegment segment;
  segment.mutable_frame()->set_x(1);
  segment.mutable_frame()->set_y(2);
  segment.mutable_frame()->set_theta(1.5707963267948966);
  segment.set_left(-1);
  segment.set_right(2);
  segment.set_left_type(v1::MapSegment::REAL);
  const SceneSegment s = SegmentEndpoints(segment);
  EXPECT_NEAR(s.a.x, 1, 1e-12);
  EXPECT_NEAR(s.a.y, 1, 1e-12);
  EXPECT_NEAR(s.b.y, 4, 1e-12);
  EXPECT_TRUE(s.a_real);
  EXPECT_FALSE(s.b_real);
}

}  // namespace
}  // namespace waymark::cli
