// Map pictures: the SVG holds one element per segment and the PNG decodes, from one layout.
#include "client/render/map_render.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>

#include "client/render/slam_output.h"
#include "client/render/text_fit.h"
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

std::vector<const DrawItem*> WithClass(const Drawing& d, const std::string& css) {
  std::vector<const DrawItem*> items;
  for (const DrawItem& item : d.items) {
    if (item.css_class == css) items.push_back(&item);
  }
  return items;
}

Vec2 Centroid(const DrawItem& item) {
  Vec2 c;
  for (const Vec2& p : item.points) {
    c.x += p.x / static_cast<double>(item.points.size());
    c.y += p.y / static_cast<double>(item.points.size());
  }
  return c;
}

// The square room's trajectory with its ends marked and the robot's current pose facing up
// (+y in the world, 90 degrees).
MapScene SquareWithPose() {
  MapScene scene = Square();
  scene.polylines[0].mark_ends = true;
  scene.current_pose = ScenePose{{3.5, 2.5}, M_PI / 2, {0, 150, 0}, "current pose"};
  return scene;
}

TEST(MapRender, TrajectoriesHaveStartAndEndMarkersAndTheCurrentPoseAnArrow) {
  const Drawing d = LayoutScene(SquareWithPose());
  const auto lines = WithClass(d, "trajectory");
  ASSERT_EQ(lines.size(), 1u);
  const auto starts = WithClass(d, "start");
  const auto ends = WithClass(d, "end");
  ASSERT_EQ(starts.size(), 1u);  // the reference (odometry) is not marked in this scene
  ASSERT_EQ(ends.size(), 1u);
  // On the path's first and last points, in its colour.
  EXPECT_NEAR(starts[0]->points[0].x, lines[0]->points.front().x, 1e-9);
  EXPECT_NEAR(starts[0]->points[0].y, lines[0]->points.front().y, 1e-9);
  EXPECT_NEAR(Centroid(*ends[0]).x, lines[0]->points.back().x, 1e-9);
  EXPECT_NEAR(Centroid(*ends[0]).y, lines[0]->points.back().y, 1e-9);
  EXPECT_EQ(starts[0]->stroke.g, 150);
  EXPECT_EQ(ends[0]->fill.g, 150);
  EXPECT_NE(starts[0]->kind, ends[0]->kind);  // told apart by shape, not only by position

  // The arrow sits at the pose and points up the picture (world +y is image -y).
  const auto arrows = WithClass(d, "current-pose");
  ASSERT_EQ(arrows.size(), 1u);
  const Vec2 tip = arrows[0]->points[0];
  const Vec2 at = lines[0]->points.back();
  EXPECT_LT(tip.y, at.y - 5);
  EXPECT_NEAR(tip.x, at.x, 1e-6);
  // Legend: start, end and current pose rows.
  EXPECT_EQ(WithClass(d, "legend start").size(), 1u);
  EXPECT_EQ(WithClass(d, "legend end").size(), 1u);
  EXPECT_EQ(WithClass(d, "legend current-pose").size(), 1u);
  const std::string svg = DrawingToSvg(d);
  EXPECT_EQ(Count(svg, "<polygon class=\"end\""), 1);
  EXPECT_EQ(Count(svg, "<polygon class=\"current-pose\""), 1);
  EXPECT_NE(svg.find("current pose</text>"), std::string::npos);
  EXPECT_NE(svg.find("start of a path</text>"), std::string::npos);

  // The PNG draws the arrow filled, in the pose's colour.
  const cv::Mat image = DrawingToImage(d);
  const Vec2 notch = arrows[0]->points[2];  // the pose; the head lies between it and the tip
  const Vec2 inside{0.5 * (tip.x + notch.x), 0.5 * (tip.y + notch.y)};
  const cv::Vec3b pixel =
      image.at<cv::Vec3b>(static_cast<int>(std::lround(inside.y)), static_cast<int>(inside.x));
  EXPECT_EQ(pixel, cv::Vec3b(0, 150, 0));  // BGR
}

TEST(MapRender, ArrowPointsAlongTheHeading) {
  MapScene scene = SquareWithPose();
  for (double heading : {0.0, M_PI / 2, M_PI, -M_PI / 4}) {
    scene.current_pose->heading = heading;
    const Drawing d = LayoutScene(scene);
    const auto arrows = WithClass(d, "current-pose");
    ASSERT_EQ(arrows.size(), 1u);
    const Vec2 tip = arrows[0]->points[0];
    const Vec2 at = arrows[0]->points[2];  // the notch: the pose itself
    const double drawn = std::atan2(-(tip.y - at.y), tip.x - at.x);
    EXPECT_NEAR(std::remainder(drawn - heading, 2 * M_PI), 0, 1e-9) << heading;
  }
}

// A title as long as a KITTI sequence's, on a picture as narrow as a camera driving straight: it
// is shrunk or wrapped, never cut off, and the map moves down to make room.
TEST(MapRender, LongTitlesFitTheWidth) {
  MapScene scene = Square();
  const std::string long_title =
      "kitti_odom06_frames000-050: 51 frames, ATE RMSE 0.1234 m (Sim(3), scale 0.123)";
  RenderOptions narrow;
  narrow.max_size_px = 300;
  narrow.min_width_px = 380;
  const double short_band = LayoutScene(scene, narrow).height;
  for (const std::string& title :
       {long_title, long_title + " " + long_title + " " + long_title,
        std::string(200, 'x')}) {  // one word wider than the picture
    SCOPED_TRACE(title);
    scene.title = title;
    const Drawing d = LayoutScene(scene, narrow);
    const auto lines = WithClass(d, "title");
    ASSERT_FALSE(lines.empty());
    std::string joined;
    for (const DrawItem* line : lines) {
      EXPECT_LE(line->points[0].x + TextWidthPx(line->text, line->font_px), d.width - 10 + 1e-9);
      EXPECT_GE(line->font_px, 11);
      joined += line->text;
    }
    std::string expected = title;
    expected.erase(std::remove(expected.begin(), expected.end(), ' '), expected.end());
    joined.erase(std::remove(joined.begin(), joined.end(), ' '), joined.end());
    EXPECT_EQ(joined, expected);  // nothing dropped
    // The map starts below the last title line.
    const double last_baseline = lines.back()->points[0].y;
    for (const DrawItem* segment : WithClass(d, "segment both-real")) {
      for (const Vec2& p : segment->points) EXPECT_GT(p.y, last_baseline);
    }
    if (lines.size() > 1) {
      EXPECT_GT(d.height, short_band);
    }
    // In the PNG, the title band's last columns stay white: no text runs off the edge.
    const cv::Mat image = DrawingToImage(d);
    const cv::Mat band = image(cv::Rect(d.width - 4, 0, 4, static_cast<int>(last_baseline) + 4));
    EXPECT_EQ(cv::countNonZero(band.reshape(1) != 255), 0);
  }
  // A title a tenth too wide is shrunk a little and stays on one line.
  scene.title = "kitti_odom06_frames000-050: 51 frames, ATE RMSE 2.8075 m";
  narrow.min_width_px = static_cast<int>(TextWidthPx(scene.title, kTitleFontPx) / 1.1) + 20;
  const auto one = WithClass(LayoutScene(scene, narrow), "title");
  ASSERT_EQ(one.size(), 1u);
  EXPECT_LT(one[0]->font_px, kTitleFontPx);
  EXPECT_GE(one[0]->font_px, 11);
}

// On a picture as narrow as the legend, every text stays inside it: the endpoint note moves from
// beside the segment rows to a row of its own.
TEST(MapRender, EveryTextFitsANarrowPicture) {
  RenderOptions narrow;
  narrow.max_size_px = 200;
  narrow.min_width_px = 380;
  MapScene scene = SquareWithPose();
  const Drawing d = LayoutScene(scene, narrow);
  bool note = false;
  for (const DrawItem& item : d.items) {
    if (item.kind != DrawItem::Kind::kText) continue;
    EXPECT_LE(item.points[0].x + TextWidthPx(item.text, item.font_px), d.width) << item.text;
    EXPECT_LE(item.points[0].y, d.height) << item.text;
    note = note || item.text.find("hollow = virtual") != std::string::npos;
  }
  EXPECT_TRUE(note);
}

TEST(TextFit, ShortTextStaysLongTextShrinksThenWraps) {
  FittedText fitted = FitText("map", 400, 14, 11);
  EXPECT_EQ(fitted.font_px, 14);
  EXPECT_EQ(fitted.lines, std::vector<std::string>{"map"});
  const std::string text = "one two three four five six seven eight nine ten";
  const double width = TextWidthPx(text, 14);
  fitted = FitText(text, 0.9 * width, 14, 11);  // shrinking suffices
  ASSERT_EQ(fitted.lines.size(), 1u);
  EXPECT_LT(fitted.font_px, 14);
  EXPECT_GE(fitted.font_px, 11);
  EXPECT_LE(TextWidthPx(text, fitted.font_px), 0.9 * width);
  fitted = FitText(text, 0.4 * width, 14, 11);  // it does not: wrapped at 14 px
  EXPECT_EQ(fitted.font_px, 14);
  ASSERT_GE(fitted.lines.size(), 3u);
  for (const std::string& line : fitted.lines) {
    EXPECT_LE(TextWidthPx(line, 14), 0.4 * width);
    EXPECT_NE(line.front(), ' ');
  }
  EXPECT_GT(TextWidthPx("WWW", 14), TextWidthPx("iii", 14));  // measured, not counted
}

TEST(SlamOutput, SceneMarksTheTrajectoryAndTheOdometryAndShowsTheLastPose) {
  v1::Trajectory trajectory;
  for (int i = 0; i < 3; ++i) {
    v1::TrajectoryPose* p = trajectory.add_poses();
    p->set_stamp(i);
    p->mutable_pose()->set_x(i);
    p->mutable_pose()->set_theta(0.3 * i);
  }
  const MapScene scene = SlamScene(v1::SegmentMap(), trajectory, "replay", {{0, 0}, {2.2, 0.1}});
  ASSERT_EQ(scene.polylines.size(), 1u);
  ASSERT_EQ(scene.references.size(), 1u);
  EXPECT_TRUE(scene.polylines[0].mark_ends);
  EXPECT_TRUE(scene.references[0].mark_ends);
  ASSERT_TRUE(scene.current_pose.has_value());
  EXPECT_DOUBLE_EQ(scene.current_pose->position.x, 2);
  EXPECT_DOUBLE_EQ(scene.current_pose->heading, 0.6);
  EXPECT_FALSE(SlamScene(v1::SegmentMap(), v1::Trajectory(), "empty").current_pose.has_value());
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
