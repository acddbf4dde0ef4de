#ifndef WAYMARK_CLIENT_RENDER_TIMELINE_PLOT_H_
#define WAYMARK_CLIENT_RENDER_TIMELINE_PLOT_H_

// Time-series plots (the paper's Figures 4-7: error, uncertainty and completeness over time) as
// stacked panels sharing one time axis. Laid out into the map renderer's Drawing (map_render.h),
// so the SVG and PNG back ends are the same ones the map pictures use.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/render/map_render.h"

namespace waymark::cli {

struct PlotSeries {
  std::string label;  // legend entry
  Rgb color;
  std::vector<Vec2> points;  // (time, value); non-finite values are left out
};

struct PlotPanel {
  std::string title;  // also the y quantity, e.g. "localisation error (m)"
  std::vector<PlotSeries> series;
  // Fixed y range (e.g. 0..1 for a share); unset = from the data, always including 0.
  std::optional<double> y_min;
  std::optional<double> y_max;
};

struct TimelinePlot {
  std::string title;
  std::string x_label = "time (s)";
  std::vector<PlotPanel> panels;  // top to bottom
};

struct TimelineOptions {
  int width_px = 900;
  int panel_height_px = 170;
};

// SVG classes: "panel-frame" (one per panel), "grid", "tick", "tick-label", "panel-title",
// "series" (one per series with at least two points), "legend", "x-label".
Drawing LayoutTimeline(const TimelinePlot& plot, const TimelineOptions& options = {});

// Tick positions: multiples of a 1-2-5 step covering [lo, hi] with about `target` intervals.
std::vector<double> Ticks(double lo, double hi, int target = 5);

// Writes the SVG and the PNG of one layout.
absl::Status WriteTimelinePictures(const TimelinePlot& plot, const std::filesystem::path& svg_path,
                                   const std::filesystem::path& png_path,
                                   const TimelineOptions& options = {});

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_TIMELINE_PLOT_H_
