#include "client/render/map_render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/ascii.h"
#include "client/render/text_fit.h"

namespace waymark::cli {
namespace {

constexpr Rgb kBlack{0, 0, 0};
constexpr Rgb kWhite{255, 255, 255};
constexpr double kMarkerRadius = 2.5;
constexpr double kSegmentWidth = 2.0;
constexpr int kLegendRow = 18;
// Trajectory ends and the current pose: big enough to find on a 1600-pixel map.
constexpr double kStartRadius = 6.0;
constexpr double kEndHalfSide = 5.5;
constexpr double kArrowLength = 22.0;  // tip to the back of the arrow head
constexpr double kArrowHalfWidth = 8.0;
constexpr Rgb kLegendGrey{60, 60, 60};
// Smallest title font before a title is wrapped instead (text_fit.h).
constexpr double kMinTitleFontPx = 11;
constexpr double kTitleMarginPx = 10;  // left and right of the title
constexpr const char* kEndpointNote = "filled marker = real endpoint, hollow = virtual";
constexpr double kNoteFontPx = 11;

struct Bounds {
  double min_x = std::numeric_limits<double>::infinity();
  double min_y = std::numeric_limits<double>::infinity();
  double max_x = -std::numeric_limits<double>::infinity();
  double max_y = -std::numeric_limits<double>::infinity();
  void Add(const Vec2& p) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return;
    min_x = std::min(min_x, p.x);
    min_y = std::min(min_y, p.y);
    max_x = std::max(max_x, p.x);
    max_y = std::max(max_y, p.y);
  }
  bool empty() const { return !(min_x <= max_x); }
};

DrawItem Line(std::vector<Vec2> points, Rgb color, double width, std::string css = {}) {
  DrawItem item;
  item.kind = DrawItem::Kind::kPolyline;
  item.points = std::move(points);
  item.stroke = color;
  item.width_px = width;
  item.css_class = std::move(css);
  return item;
}

DrawItem Marker(Vec2 at, Rgb color, bool real) {
  DrawItem item;
  item.kind = DrawItem::Kind::kCircle;
  item.points = {at};
  item.stroke = color;
  item.width_px = 1.0;
  item.filled = real;
  item.fill = real ? color : kWhite;
  item.radius_px = kMarkerRadius;
  item.css_class = real ? "endpoint real" : "endpoint virtual";
  return item;
}

DrawItem Text(Vec2 at, std::string text, double font_px = 12) {
  return TextItem(at, std::move(text), font_px);
}

DrawItem Polygon(std::vector<Vec2> points, Rgb color, std::string css) {
  DrawItem item;
  item.kind = DrawItem::Kind::kPolygon;
  item.points = std::move(points);
  item.stroke = color;
  item.fill = color;
  item.filled = true;
  item.width_px = 1.0;
  item.css_class = std::move(css);
  return item;
}

// Where a trajectory starts: a hollow circle in its colour.
DrawItem StartMarker(Vec2 at, Rgb color) {
  DrawItem item;
  item.kind = DrawItem::Kind::kCircle;
  item.points = {at};
  item.stroke = color;
  item.width_px = 2.0;
  item.fill = kWhite;
  item.radius_px = kStartRadius;
  item.css_class = "start";
  return item;
}

// Where it ends: a filled square.
DrawItem EndMarker(Vec2 at, Rgb color) {
  const double h = kEndHalfSide;
  return Polygon({{at.x - h, at.y - h}, {at.x + h, at.y - h}, {at.x + h, at.y + h},
                  {at.x - h, at.y + h}},
                 color, "end");
}

// An arrow head with its tip `kArrowLength` ahead of `at` along `heading` (world radians; the
// image's y axis points down, so a world angle turns the other way on screen).
DrawItem PoseArrow(Vec2 at, double heading, Rgb color) {
  const Vec2 ahead{std::cos(heading), -std::sin(heading)};
  const Vec2 side{-ahead.y, ahead.x};
  const double back = 0.35 * kArrowLength;  // the pose sits inside the head, towards its back
  const Vec2 tip{at.x + ahead.x * (kArrowLength - back), at.y + ahead.y * (kArrowLength - back)};
  const Vec2 base{at.x - ahead.x * back, at.y - ahead.y * back};
  const Vec2 notch{at.x, at.y};
  return Polygon({tip,
                  {base.x + side.x * kArrowHalfWidth, base.y + side.y * kArrowHalfWidth},
                  notch,
                  {base.x - side.x * kArrowHalfWidth, base.y - side.y * kArrowHalfWidth}},
                 color, "current-pose");
}

bool HasMarkedEnds(const MapScene& scene) {
  for (const auto* list : {&scene.polylines, &scene.references}) {
    for (const ScenePolyline& line : *list) {
      if (line.mark_ends && !line.points.empty()) return true;
    }
  }
  return false;
}

std::string Hex(Rgb c) { return fmt::format("#{:02x}{:02x}{:02x}", c.r, c.g, c.b); }

std::string EscapeXml(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

cv::Scalar Bgr(Rgb c) { return cv::Scalar(c.b, c.g, c.r); }

// OpenCV draws with sub-pixel precision through fixed-point coordinates.
constexpr int kShift = 4;
cv::Point Fixed(const Vec2& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                   static_cast<int>(std::lround(p.y * (1 << kShift))));
}

}  // namespace

SegmentClass ClassOf(const SceneSegment& s) {
  if (s.a_real && s.b_real) return SegmentClass::kBothReal;
  if (s.a_real || s.b_real) return SegmentClass::kOneReal;
  return SegmentClass::kBothVirtual;
}

Rgb ColorOf(SegmentClass c) {
  switch (c) {
    case SegmentClass::kBothReal: return {20, 70, 190};      // blue
    case SegmentClass::kOneReal: return {230, 130, 0};       // orange
    case SegmentClass::kBothVirtual: return {190, 30, 120};  // magenta
  }
  return kBlack;
}

const char* CssClassOf(SegmentClass c) {
  switch (c) {
    case SegmentClass::kBothReal: return "both-real";
    case SegmentClass::kOneReal: return "one-real";
    case SegmentClass::kBothVirtual: return "both-virtual";
  }
  return "";
}

double NiceLength(double target_m) {
  if (!(target_m > 0) || !std::isfinite(target_m)) return 1.0;
  const double power = std::pow(10.0, std::floor(std::log10(target_m)));
  const double mantissa = target_m / power;
  const double nice = mantissa < 1.5 ? 1 : mantissa < 3.5 ? 2 : mantissa < 7.5 ? 5 : 10;
  return nice * power;
}

Drawing LayoutScene(const MapScene& scene, const RenderOptions& options) {
  Bounds bounds;
  for (const SceneSegment& s : scene.segments) {
    bounds.Add(s.a);
    bounds.Add(s.b);
  }
  for (const auto* list : {&scene.polylines, &scene.references}) {
    for (const ScenePolyline& line : *list) {
      for (const Vec2& p : line.points) bounds.Add(p);
    }
  }
  if (bounds.empty()) bounds = Bounds{-1, -1, 1, 1};
  const double extent_x = std::max(bounds.max_x - bounds.min_x, options.min_extent_m);
  const double extent_y = std::max(bounds.max_y - bounds.min_y, options.min_extent_m);
  const double centre_x = 0.5 * (bounds.min_x + bounds.max_x);
  const double centre_y = 0.5 * (bounds.min_y + bounds.max_y);
  const double scale = options.max_size_px / std::max(extent_x, extent_y);
  const int margin = options.margin_px;

  Drawing drawing;
  drawing.pixels_per_metre = scale;
  const double map_w = extent_x * scale;
  const double map_h = extent_y * scale;
  drawing.width = std::max(options.min_width_px, static_cast<int>(std::ceil(map_w)) + 2 * margin);

  // Legend rows: three segment classes (and their note, beside them when it fits), the labelled
  // polylines, the end markers, the pose.
  const double label_x = margin + 46;
  const double note_x = label_x + 230;
  const bool note_beside =
      note_x + TextWidthPx(kEndpointNote, kNoteFontPx) <= drawing.width - kTitleMarginPx;
  const bool marked_ends = HasMarkedEnds(scene);
  int legend_rows = options.segment_legend ? (note_beside ? 3 : 4) : 0;
  for (const auto* list : {&scene.polylines, &scene.references}) {
    for (const ScenePolyline& line : *list) legend_rows += line.label.empty() ? 0 : 1;
  }
  legend_rows += marked_ends ? 2 : 0;
  legend_rows += scene.current_pose && !scene.current_pose->label.empty() ? 1 : 0;
  const int legend_band = 16 + kLegendRow * legend_rows;
  const int title_band =
      LayoutTitle(scene.title, drawing.width, kTitleFontPx, "title", drawing.items);
  drawing.height = title_band + static_cast<int>(std::ceil(map_h)) + 2 * margin + legend_band;
  const double origin_x = 0.5 * drawing.width;
  const double origin_y = title_band + margin + 0.5 * map_h;
  auto to_px = [&](const Vec2& p) {
    return Vec2{origin_x + (p.x - centre_x) * scale, origin_y - (p.y - centre_y) * scale};
  };
  auto polyline_px = [&](const ScenePolyline& line) {
    std::vector<Vec2> points;
    points.reserve(line.points.size());
    for (const Vec2& p : line.points) points.push_back(to_px(p));
    return points;
  };

  for (const ScenePolyline& line : scene.references) {
    if (line.points.size() >= 2) {
      drawing.items.push_back(Line(polyline_px(line), line.color, line.width_px, "reference"));
    }
  }
  for (const SceneSegment& s : scene.segments) {
    const SegmentClass c = ClassOf(s);
    drawing.items.push_back(Line({to_px(s.a), to_px(s.b)}, ColorOf(c), kSegmentWidth,
                                 std::string("segment ") + CssClassOf(c)));
  }
  for (const SceneSegment& s : scene.segments) {
    const Rgb color = ColorOf(ClassOf(s));
    drawing.items.push_back(Marker(to_px(s.a), color, s.a_real));
    drawing.items.push_back(Marker(to_px(s.b), color, s.b_real));
  }
  for (const ScenePolyline& line : scene.polylines) {
    if (line.points.size() >= 2) {
      drawing.items.push_back(Line(polyline_px(line), line.color, line.width_px, "trajectory"));
    }
  }
  // Ends over all lines, so another path does not hide them.
  for (const auto* list : {&scene.references, &scene.polylines}) {
    for (const ScenePolyline& line : *list) {
      if (!line.mark_ends || line.points.empty()) continue;
      drawing.items.push_back(StartMarker(to_px(line.points.front()), line.color));
      drawing.items.push_back(EndMarker(to_px(line.points.back()), line.color));
    }
  }
  if (scene.current_pose) {
    drawing.items.push_back(PoseArrow(to_px(scene.current_pose->position),
                                      scene.current_pose->heading, scene.current_pose->color));
  }

  // Scale bar, bottom left of the map area: about a fifth of the map's width.
  const double bar_m = NiceLength(0.2 * std::max(extent_x, extent_y));
  const double bar_px = bar_m * scale;
  const double bar_y = title_band + map_h + margin + 0.5 * margin;
  const double bar_x = margin;
  drawing.items.push_back(Line({{bar_x, bar_y}, {bar_x + bar_px, bar_y}}, kBlack, 2, "scale-bar"));
  drawing.items.push_back(Line({{bar_x, bar_y - 5}, {bar_x, bar_y + 5}}, kBlack, 1, "scale-bar"));
  drawing.items.push_back(
      Line({{bar_x + bar_px, bar_y - 5}, {bar_x + bar_px, bar_y + 5}}, kBlack, 1, "scale-bar"));
  drawing.items.push_back(Text({bar_x + bar_px + 8, bar_y + 4}, fmt::format("{:g} m", bar_m)));

  // Legend under the scale bar: one row per entry, a sample and its label.
  double row_y = title_band + map_h + 2 * margin + 8;
  const double sample_x0 = margin, sample_x1 = margin + 36;
  const std::pair<SegmentClass, const char*> classes[] = {
      {SegmentClass::kBothReal, "segment, both endpoints real"},
      {SegmentClass::kOneReal, "segment, one endpoint real"},
      {SegmentClass::kBothVirtual, "segment, both endpoints virtual"},
  };
  for (const auto& [c, label] : classes) {
    if (!options.segment_legend) break;
    const Rgb color = ColorOf(c);
    drawing.items.push_back(
        Line({{sample_x0, row_y}, {sample_x1, row_y}}, color, kSegmentWidth, "legend"));
    drawing.items.push_back(Marker({sample_x0, row_y}, color, c != SegmentClass::kBothVirtual));
    drawing.items.push_back(Marker({sample_x1, row_y}, color, c == SegmentClass::kBothReal));
    drawing.items.push_back(Text({label_x, row_y + 4}, label));
    row_y += kLegendRow;
  }
  if (options.segment_legend && note_beside) {
    drawing.items.push_back(
        Text({note_x, title_band + map_h + 2 * margin + 12}, kEndpointNote, kNoteFontPx));
  } else if (options.segment_legend) {  // a narrow picture: on a row of its own
    drawing.items.push_back(Text({sample_x0, row_y + 4}, kEndpointNote, kNoteFontPx));
    row_y += kLegendRow;
  }
  for (const auto* list : {&scene.polylines, &scene.references}) {
    for (const ScenePolyline& line : *list) {
      if (line.label.empty()) continue;
      drawing.items.push_back(
          Line({{sample_x0, row_y}, {sample_x1, row_y}}, line.color, line.width_px, "legend"));
      drawing.items.push_back(Text({label_x, row_y + 4}, line.label));
      row_y += kLegendRow;
    }
  }
  const double sample_mid = 0.5 * (sample_x0 + sample_x1);
  if (marked_ends) {
    DrawItem start = StartMarker({sample_mid, row_y}, kLegendGrey);
    start.css_class = "legend start";
    drawing.items.push_back(start);
    drawing.items.push_back(Text({label_x, row_y + 4}, "start of a path"));
    row_y += kLegendRow;
    DrawItem end = EndMarker({sample_mid, row_y}, kLegendGrey);
    end.css_class = "legend end";
    drawing.items.push_back(end);
    drawing.items.push_back(Text({label_x, row_y + 4}, "end of a path"));
    row_y += kLegendRow;
  }
  if (scene.current_pose && !scene.current_pose->label.empty()) {
    DrawItem arrow = PoseArrow({sample_mid, row_y}, 0, scene.current_pose->color);
    arrow.css_class = "legend current-pose";
    drawing.items.push_back(arrow);
    drawing.items.push_back(Text({label_x, row_y + 4}, scene.current_pose->label));
    row_y += kLegendRow;
  }
  return drawing;
}

int LayoutTitle(const std::string& title, int width, double font_px, const std::string& css_class,
                std::vector<DrawItem>& items) {
  if (title.empty()) return 0;
  constexpr double kLeft = kTitleMarginPx;
  const FittedText fitted = FitText(title, width - 2 * kLeft, font_px, kMinTitleFontPx);
  const double line_height = std::round(1.35 * fitted.font_px);
  for (size_t i = 0; i < fitted.lines.size(); ++i) {
    items.push_back(TextItem({kLeft, 3 + fitted.font_px + static_cast<double>(i) * line_height},
                             fitted.lines[i], fitted.font_px, css_class));
  }
  return static_cast<int>(std::ceil(5 + line_height * static_cast<double>(fitted.lines.size())));
}

std::string DrawingToSvg(const Drawing& d) {
  std::string svg = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n",
      d.width, d.height);
  for (const DrawItem& item : d.items) {
    const std::string css =
        item.css_class.empty() ? "" : fmt::format(" class=\"{}\"", item.css_class);
    switch (item.kind) {
      case DrawItem::Kind::kPolyline: {
        if (item.points.size() == 2) {
          svg += fmt::format(
              "<line{} x1=\"{:.2f}\" y1=\"{:.2f}\" x2=\"{:.2f}\" y2=\"{:.2f}\" stroke=\"{}\" "
              "stroke-width=\"{:g}\" stroke-linecap=\"round\"/>\n",
              css, item.points[0].x, item.points[0].y, item.points[1].x, item.points[1].y,
              Hex(item.stroke), item.width_px);
        } else {
          svg += fmt::format("<polyline{} fill=\"none\" stroke=\"{}\" stroke-width=\"{:g}\" "
                             "stroke-linejoin=\"round\" points=\"",
                             css, Hex(item.stroke), item.width_px);
          for (size_t i = 0; i < item.points.size(); ++i) {
            svg += fmt::format("{}{:.2f},{:.2f}", i ? " " : "", item.points[i].x,
                               item.points[i].y);
          }
          svg += "\"/>\n";
        }
        break;
      }
      case DrawItem::Kind::kCircle:
        svg += fmt::format(
            "<circle{} cx=\"{:.2f}\" cy=\"{:.2f}\" r=\"{:g}\" fill=\"{}\" stroke=\"{}\" "
            "stroke-width=\"{:g}\"/>\n",
            css, item.points[0].x, item.points[0].y, item.radius_px, Hex(item.fill),
            Hex(item.stroke), item.width_px);
        break;
      case DrawItem::Kind::kText:
        svg += fmt::format(
            "<text{} x=\"{:.1f}\" y=\"{:.1f}\" font-family=\"sans-serif\" font-size=\"{:g}\" "
            "fill=\"{}\">{}</text>\n",
            css, item.points[0].x, item.points[0].y, item.font_px, Hex(item.stroke),
            EscapeXml(item.text));
        break;
      case DrawItem::Kind::kPolygon: {
        svg += fmt::format("<polygon{} fill=\"{}\" stroke=\"{}\" stroke-width=\"{:g}\" "
                           "stroke-linejoin=\"round\" points=\"",
                           css, Hex(item.fill), Hex(item.stroke), item.width_px);
        for (size_t i = 0; i < item.points.size(); ++i) {
          svg += fmt::format("{}{:.2f},{:.2f}", i ? " " : "", item.points[i].x, item.points[i].y);
        }
        svg += "\"/>\n";
        break;
      }
    }
  }
  svg += "</svg>\n";
  return svg;
}

cv::Mat DrawingToImage(const Drawing& d) {
  cv::Mat image(std::max(1, d.height), std::max(1, d.width), CV_8UC3, cv::Scalar(255, 255, 255));
  DrawItemsOn(d.items, image);
  return image;
}

void DrawItemsOn(const std::vector<DrawItem>& items, cv::Mat& image) {
  for (const DrawItem& item : items) {
    const int thickness = std::max(1, static_cast<int>(std::lround(item.width_px)));
    switch (item.kind) {
      case DrawItem::Kind::kPolyline: {
        std::vector<cv::Point> points;
        points.reserve(item.points.size());
        for (const Vec2& p : item.points) points.push_back(Fixed(p));
        cv::polylines(image, std::vector<std::vector<cv::Point>>{points}, false, Bgr(item.stroke),
                      thickness, cv::LINE_AA, kShift);
        break;
      }
      case DrawItem::Kind::kCircle: {
        const int radius = static_cast<int>(std::lround(item.radius_px * (1 << kShift)));
        cv::circle(image, Fixed(item.points[0]), radius, Bgr(item.fill), cv::FILLED, cv::LINE_AA,
                   kShift);
        cv::circle(image, Fixed(item.points[0]), radius, Bgr(item.stroke), thickness, cv::LINE_AA,
                   kShift);
        break;
      }
      case DrawItem::Kind::kText: {
        // Hershey simplex: scale 1 is about 22 px tall for capitals+descenders.
        const double font_scale = item.font_px / 28.0;
        cv::putText(image, item.text,
                    cv::Point(static_cast<int>(std::lround(item.points[0].x)),
                              static_cast<int>(std::lround(item.points[0].y))),
                    cv::FONT_HERSHEY_SIMPLEX, font_scale, Bgr(item.stroke), 1, cv::LINE_AA);
        break;
      }
      case DrawItem::Kind::kPolygon: {
        std::vector<cv::Point> points;
        points.reserve(item.points.size());
        for (const Vec2& p : item.points) points.push_back(Fixed(p));
        const std::vector<std::vector<cv::Point>> contours{points};
        cv::fillPoly(image, contours, Bgr(item.fill), cv::LINE_AA, kShift);
        cv::polylines(image, contours, true, Bgr(item.stroke), thickness, cv::LINE_AA, kShift);
        break;
      }
    }
  }
}

std::vector<DrawItem> PathItems(const std::vector<Vec2>& points_px, Rgb color, double width_px) {
  std::vector<DrawItem> items;
  if (points_px.empty()) return items;
  if (points_px.size() >= 2) items.push_back(Line(points_px, color, width_px, "trajectory"));
  items.push_back(StartMarker(points_px.front(), color));
  items.push_back(EndMarker(points_px.back(), color));
  return items;
}

std::string RenderSvg(const MapScene& scene, const RenderOptions& options) {
  return DrawingToSvg(LayoutScene(scene, options));
}

cv::Mat RenderImage(const MapScene& scene, const RenderOptions& options) {
  return DrawingToImage(LayoutScene(scene, options));
}

namespace {

absl::Status WriteSvgFile(const Drawing& drawing, const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError("cannot write '" + path.string() + "'");
  out << DrawingToSvg(drawing);
  out.close();
  if (!out) return absl::DataLossError("writing '" + path.string() + "' failed");
  return absl::OkStatus();
}

absl::Status WritePngFile(const Drawing& drawing, const std::filesystem::path& path) {
  return WritePngImage(DrawingToImage(drawing), path);
}

}  // namespace

absl::Status WritePngImage(const cv::Mat& image, const std::filesystem::path& path) {
  try {
    if (!cv::imwrite(path.string(), image)) {
      return absl::PermissionDeniedError("cannot write '" + path.string() + "'");
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError("writing '" + path.string() + "': " + e.what());
  }
  return absl::OkStatus();
}

absl::Status WriteDrawing(const Drawing& drawing, const std::filesystem::path& svg_path,
                          const std::filesystem::path& png_path) {
  if (absl::Status s = WriteSvgFile(drawing, svg_path); !s.ok()) return s;
  return WritePngFile(drawing, png_path);
}

absl::Status WriteDrawingFile(const Drawing& drawing, const std::filesystem::path& path) {
  const std::string ext = absl::AsciiStrToLower(path.extension().string());
  if (ext == ".svg") return WriteSvgFile(drawing, path);
  if (ext == ".png") return WritePngFile(drawing, path);
  return absl::InvalidArgumentError("a picture needs a .svg or .png file name, got '" +
                                    path.string() + "'");
}

absl::Status WriteMapPictures(const MapScene& scene, const std::filesystem::path& svg_path,
                              const std::filesystem::path& png_path, const RenderOptions& options) {
  return WriteDrawing(LayoutScene(scene, options), svg_path, png_path);
}

DrawItem TextItem(Vec2 at, std::string text, double font_px, std::string css_class) {
  DrawItem item;
  item.kind = DrawItem::Kind::kText;
  item.points = {at};
  item.stroke = kBlack;
  item.text = std::move(text);
  item.font_px = font_px;
  item.css_class = std::move(css_class);
  return item;
}

}  // namespace waymark::cli
