// Timeline plots: stacked panels with axes, ticks, legend; SVG and PNG from one layout.
#include "client/render/timeline_plot.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

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

std::vector<const DrawItem*> WithClass(const Drawing& d, const std::string& css) {
  std::vector<const DrawItem*> items;
  for (const DrawItem& item : d.items) {
    if (item.css_class == css) items.push_back(&item);
  }
  return items;
}

TimelinePlot ThreePanels() {
  PlotSeries error{"SLAM estimate", {220, 30, 30}, {{0, 0}, {4, 0.05}, {8, 0.08}, {12, 0.1}}};
  PlotSeries odometry{"odometry only", {150, 150, 150}, {{0, 0}, {4, 0.1}, {8, 0.3}, {12, 0.5}}};
  PlotSeries trace{"mean trace", {20, 70, 190}, {{0, 0.001}, {4, 0.004}, {8, 0.003}, {12, 0.006}}};
  PlotSeries done{"completeness", {30, 150, 60}, {{0, 0.1}, {4, 0.3}, {8, 0.6}, {12, 1.2}}};
  TimelinePlot plot;
  plot.title = "corridor (active, seed 1)";
  plot.x_label = "simulated time (s)";
  plot.panels = {{"localisation error (m)", {error, odometry}, std::nullopt, std::nullopt},
                 {"mean covariance trace", {trace}, std::nullopt, std::nullopt},
                 {"map completeness", {done}, 0.0, 1.0}};
  return plot;
}

TEST(TimelinePlot, TicksAreNiceSteps) {
  const std::vector<double> tenths = Ticks(0, 1, 5);
  ASSERT_EQ(tenths.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(tenths[i], 0.2 * i, 1e-12);
  EXPECT_EQ(Ticks(0, 300, 6), (std::vector<double>{0, 50, 100, 150, 200, 250, 300}));
  EXPECT_EQ(Ticks(3, 17, 2), (std::vector<double>{5, 10, 15}));
  EXPECT_TRUE(Ticks(1, 1).empty());
}

TEST(TimelinePlot, OnePanelFramePerPanelAndOneLinePerSeries) {
  const Drawing d = LayoutTimeline(ThreePanels());
  const auto frames = WithClass(d, "panel-frame");
  ASSERT_EQ(frames.size(), 3u);
  const auto series = WithClass(d, "series");
  ASSERT_EQ(series.size(), 4u);
  EXPECT_EQ(WithClass(d, "panel-title").size(), 3u);
  EXPECT_GE(WithClass(d, "tick-label").size(), 3u * 4);
  // Panels are stacked top to bottom without overlapping, inside the picture.
  for (size_t i = 0; i < frames.size(); ++i) {
    const double top = frames[i]->points[0].y, bottom = frames[i]->points[2].y;
    EXPECT_LT(top, bottom);
    EXPECT_LE(bottom, d.height);
    if (i > 0) EXPECT_GT(top, frames[i - 1]->points[2].y);
  }
  // Every series stays inside its panel's frame (the 1.2 completeness is pinned to the top), and
  // time runs left to right over the full width.
  const int panel_of_series[] = {0, 0, 1, 2};
  for (size_t s = 0; s < series.size(); ++s) {
    const DrawItem& frame = *frames[panel_of_series[s]];
    for (const Vec2& p : series[s]->points) {
      EXPECT_GE(p.y, frame.points[0].y - 1e-9);
      EXPECT_LE(p.y, frame.points[2].y + 1e-9);
    }
    EXPECT_NEAR(series[s]->points.front().x, frame.points[0].x, 1e-9);
    EXPECT_NEAR(series[s]->points.back().x, frame.points[1].x, 1e-9);
  }
  EXPECT_NEAR(series[3]->points.back().y, frames[2]->points[0].y, 1e-9);
  // A larger error is drawn higher (smaller row).
  EXPECT_LT(series[1]->points.back().y, series[0]->points.back().y);
}

TEST(TimelinePlot, SvgIsWellFormedAndLabelled) {
  const std::string svg = DrawingToSvg(LayoutTimeline(ThreePanels()));
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(Count(svg, "<text"), Count(svg, "</text>"));
  EXPECT_EQ(Count(svg, "<svg"), 1);
  for (const char* label :
       {"localisation error (m)", "mean covariance trace", "map completeness", "SLAM estimate",
        "odometry only", "simulated time (s)", "corridor (active, seed 1)"}) {
    EXPECT_NE(svg.find(label), std::string::npos) << label;
  }
  EXPECT_EQ(Count(svg, "class=\"panel-frame\""), 3);
  EXPECT_NE(svg.find(">0.5</text>"), std::string::npos);  // a completeness tick
}

TEST(TimelinePlot, PngIsDrawnAndBothFilesAreWritten) {
  const cv::Mat image = DrawingToImage(LayoutTimeline(ThreePanels()));
  ASSERT_FALSE(image.empty());
  cv::Mat gray;
  cv::extractChannel(image, gray, 0);
  EXPECT_GT(cv::countNonZero(gray < 200), 1000);  // axes, text and lines, not a blank page

  ScopedTempDir dir;
  ASSERT_TRUE(
      WriteTimelinePictures(ThreePanels(), dir.path() / "t.svg", dir.path() / "t.png").ok());
  EXPECT_FALSE(cv::imread((dir.path() / "t.png").string()).empty());
  EXPECT_GT(std::filesystem::file_size(dir.path() / "t.svg"), 1000u);
}

// A title wider than the plot wraps, and the panels move down below it.
TEST(TimelinePlot, LongTitleWrapsAndThePanelsMoveDown) {
  TimelinePlot plot = ThreePanels();
  const double top = WithClass(LayoutTimeline(plot), "panel-frame")[0]->points[0].y;
  for (int i = 0; i < 6; ++i) plot.title += " and a much longer description of the run";
  TimelineOptions options;
  options.width_px = 500;
  const Drawing d = LayoutTimeline(plot, options);
  const auto titles = WithClass(d, "title");
  ASSERT_GT(titles.size(), 1u);
  for (const DrawItem* line : titles) {
    EXPECT_LE(line->points[0].x + TextWidthPx(line->text, line->font_px), d.width);
  }
  const auto frames = WithClass(d, "panel-frame");
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_GT(frames[0]->points[0].y, top);
  EXPECT_GT(WithClass(d, "panel-title")[0]->points[0].y, titles.back()->points[0].y + 10);
}

TEST(TimelinePlot, EmptyAndSingleSampleSeriesDoNotBreakTheLayout) {
  TimelinePlot plot;
  plot.panels = {{"one sample", {{"x", {0, 0, 0}, {{5, 1}}}}, std::nullopt, std::nullopt},
                 {"nothing", {}, std::nullopt, std::nullopt}};
  const Drawing d = LayoutTimeline(plot);
  EXPECT_EQ(WithClass(d, "panel-frame").size(), 2u);
  ASSERT_EQ(WithClass(d, "series").size(), 1u);
  EXPECT_EQ(WithClass(d, "series")[0]->kind, DrawItem::Kind::kCircle);
}

}  // namespace
}  // namespace waymark::cli
