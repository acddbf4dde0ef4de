#include "client/render/timeline_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "client/render/text_fit.h"

namespace waymark::cli {
namespace {

constexpr Rgb kBlack{0, 0, 0};
constexpr Rgb kGrid{225, 225, 225};
constexpr int kLeft = 70;  // room for the y tick labels
constexpr int kRight = 20;
constexpr int kTitleGap = 6;    // between the plot's title and the first panel's title
constexpr int kPanelGap = 46;   // x tick labels of one panel + title of the next
constexpr int kBottom = 50;     // x tick labels + x label of the last panel
constexpr double kTickFont = 10;
constexpr int kLegendRow = 15;

DrawItem Line(std::vector<Vec2> points, Rgb color, double width, std::string css) {
  DrawItem item;
  item.points = std::move(points);
  item.stroke = color;
  item.width_px = width;
  item.css_class = std::move(css);
  return item;
}

DrawItem Text(Vec2 at, std::string text, double font_px, std::string css) {
  return TextItem(at, std::move(text), font_px, std::move(css));
}

// Text items are anchored at their left end: right-aligned and centred labels need their width.
double TextWidth(const std::string& text, double font_px) { return TextWidthPx(text, font_px); }

std::string TickLabel(double value) {
  if (std::abs(value) < 1e-12) value = 0;  // no "-0"
  return fmt::format("{:g}", value);
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return !(lo <= hi); }
};

// The y range of a panel: the fixed bounds where given, else the data's range with 0 included
// (errors and traces are compared against zero), widened outward to whole tick steps so the
// frame's top and bottom carry a label.
Range PanelRange(const PlotPanel& panel) {
  Range data;
  data.Add(0);
  for (const PlotSeries& s : panel.series) {
    for (const Vec2& p : s.points) {
      if (std::isfinite(p.x)) data.Add(p.y);
    }
  }
  Range r{panel.y_min.value_or(data.lo), panel.y_max.value_or(data.hi)};
  if (!(r.hi > r.lo)) r.hi = r.lo + 1;
  const double step = NiceLength((r.hi - r.lo) / 4);
  if (!panel.y_min) r.lo = std::floor(r.lo / step + 1e-9) * step;
  if (!panel.y_max) r.hi = std::ceil(r.hi / step - 1e-9) * step;
  return r;
}

}  // namespace

std::vector<double> Ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi) || target < 1) return ticks;
  const double step = NiceLength((hi - lo) / target);
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k += 1) {
    ticks.push_back(k * step);
  }
  return ticks;
}

Drawing LayoutTimeline(const TimelinePlot& plot, const TimelineOptions& options) {
  Range x;
  for (const PlotPanel& panel : plot.panels) {
    for (const PlotSeries& s : panel.series) {
      for (const Vec2& p : s.points) x.Add(p.x);
    }
  }
  if (x.empty()) x = {0, 1};
  if (!(x.hi > x.lo)) x.hi = x.lo + 1;

  const int panels = static_cast<int>(plot.panels.size());
  const double plot_w = std::max(100, options.width_px - kLeft - kRight);
  const double panel_h = std::max(40, options.panel_height_px);
  Drawing drawing;
  drawing.width = std::max(options.width_px, kLeft + kRight + 100);
  // The title shrunk or wrapped to the width (map_render.h), not cut off.
  const int title_band =
      plot.title.empty()
          ? 10
          : LayoutTitle(plot.title, drawing.width, kTitleFontPx, "title", drawing.items) +
                kTitleGap;
  drawing.height = static_cast<int>(title_band + kPanelGap / 2 + panels * panel_h +
                                    std::max(0, panels - 1) * kPanelGap + kBottom);
  drawing.pixels_per_metre = 1;  // not a map: no metric scale

  const double x0 = kLeft, x1 = kLeft + plot_w;
  auto px_x = [&](double t) { return x0 + (t - x.lo) / (x.hi - x.lo) * plot_w; };
  for (int i = 0; i < panels; ++i) {
    const PlotPanel& panel = plot.panels[i];
    const double top = title_band + kPanelGap / 2 + i * (panel_h + kPanelGap);
    const double bottom = top + panel_h;
    const Range y = PanelRange(panel);
    // Values outside a fixed range are pinned to the frame rather than drawn over other panels.
    auto px_y = [&](double v) {
      return std::clamp(bottom - (v - y.lo) / (y.hi - y.lo) * panel_h, top, bottom);
    };

    drawing.items.push_back(Text({x0, top - 7}, panel.title, 12, "panel-title"));
    for (double v : Ticks(y.lo, y.hi, 4)) {
      const double py = px_y(v);
      drawing.items.push_back(Line({{x0, py}, {x1, py}}, kGrid, 1, "grid"));
      drawing.items.push_back(Line({{x0 - 4, py}, {x0, py}}, kBlack, 1, "tick"));
      const std::string label = TickLabel(v);
      drawing.items.push_back(
          Text({x0 - 7 - TextWidth(label, kTickFont), py + 3.5}, label, kTickFont, "tick-label"));
    }
    for (double t : Ticks(x.lo, x.hi, 8)) {
      const double px = px_x(t);
      drawing.items.push_back(Line({{px, bottom}, {px, bottom + 4}}, kBlack, 1, "tick"));
      const std::string label = TickLabel(t);
      drawing.items.push_back(Text({px - 0.5 * TextWidth(label, kTickFont), bottom + 15}, label,
                                   kTickFont, "tick-label"));
    }
    drawing.items.push_back(Line({{x0, top}, {x1, top}, {x1, bottom}, {x0, bottom}, {x0, top}},
                                 kBlack, 1, "panel-frame"));

    for (const PlotSeries& s : panel.series) {
      std::vector<Vec2> points;
      for (const Vec2& p : s.points) {
        if (std::isfinite(p.x) && std::isfinite(p.y)) points.push_back({px_x(p.x), px_y(p.y)});
      }
      if (points.size() >= 2) {
        drawing.items.push_back(Line(std::move(points), s.color, 1.5, "series"));
      } else if (points.size() == 1) {  // a lone sample would be invisible as a line
        DrawItem dot;
        dot.kind = DrawItem::Kind::kCircle;
        dot.points = points;
        dot.stroke = dot.fill = s.color;
        dot.filled = true;
        dot.radius_px = 2.5;
        dot.css_class = "series";
        drawing.items.push_back(dot);
      }
    }

    // Legend in the panel's top right corner, one row per labelled series.
    double legend_w = 0;
    for (const PlotSeries& s : panel.series) legend_w = std::max(legend_w, TextWidth(s.label, 11));
    const double lx = x1 - legend_w - 50;  // the PNG's Hershey font runs wider than the SVG's
    double ly = top + 14;
    for (const PlotSeries& s : panel.series) {
      if (s.label.empty()) continue;
      drawing.items.push_back(Line({{lx, ly - 4}, {lx + 24, ly - 4}}, s.color, 2, "legend"));
      drawing.items.push_back(Text({lx + 30, ly}, s.label, 11, "legend"));
      ly += kLegendRow;
    }
  }
  if (panels > 0) {
    const double last_bottom =
        title_band + kPanelGap / 2 + panels * panel_h + (panels - 1) * kPanelGap;
    drawing.items.push_back(
        Text({x0 + 0.5 * plot_w - TextWidth(plot.x_label, 12) / 2, last_bottom + 36}, plot.x_label,
             12, "x-label"));
  }
  return drawing;
}

absl::Status WriteTimelinePictures(const TimelinePlot& plot, const std::filesystem::path& svg_path,
                                   const std::filesystem::path& png_path,
                                   const TimelineOptions& options) {
  return WriteDrawing(LayoutTimeline(plot, options), svg_path, png_path);
}

}  // namespace waymark::cli
