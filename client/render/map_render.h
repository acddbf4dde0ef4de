#ifndef WAYMARK_CLIENT_RENDER_MAP_RENDER_H_
#define WAYMARK_CLIENT_RENDER_MAP_RENDER_H_

// Pictures of segment maps. One scene description (segments with endpoint types, polylines such as
// the trajectory, optional reference polylines) is laid out once into a drawing in pixel
// coordinates (world y up, image y down; scale bar and legend placed there); the SVG and PNG back
// ends only serialise that drawing, so both pictures show the same geometry.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"

namespace waymark::cli {

struct Vec2 {
  double x = 0;
  double y = 0;
};

struct Rgb {
  uint8_t r = 0;
  uint8_t g = 0;
  uint8_t b = 0;
};

// A map segment from endpoint a to endpoint b; an endpoint is real (observed as a corner or the
// end of a wall) or virtual (only where the wall stopped being seen).
struct SceneSegment {
  Vec2 a;
  Vec2 b;
  bool a_real = false;
  bool b_real = false;
};

struct ScenePolyline {
  std::vector<Vec2> points;  // world metres
  Rgb color;
  double width_px = 1.0;
  std::string label;  // legend entry; empty = none
};

struct MapScene {
  std::string title;
  std::vector<SceneSegment> segments;
  std::vector<ScenePolyline> polylines;   // drawn over the segments (e.g. the trajectory)
  std::vector<ScenePolyline> references;  // drawn under everything (e.g. a reference path)
};

struct RenderOptions {
  int max_size_px = 1600;  // the longer side of the map area
  int margin_px = 40;
  int min_width_px = 480;  // room for the legend
  // Smallest extent of the view each way (m), so a straight corridor or a single pose still has
  // an area. A hand-held camera's few centimetres want less than a building's map.
  double min_extent_m = 1.0;
  // Legend rows for the segment classes; off for scenes without segments (visual odometry).
  bool segment_legend = true;
};

// Endpoint-type classes and their colours (also the legend).
enum class SegmentClass { kBothReal, kOneReal, kBothVirtual };
SegmentClass ClassOf(const SceneSegment& segment);
Rgb ColorOf(SegmentClass segment_class);
const char* CssClassOf(SegmentClass segment_class);  // "both-real", "one-real", "both-virtual"

// The drawing: primitives in pixel coordinates (origin top left, y down).
struct DrawItem {
  enum class Kind { kPolyline, kCircle, kText };
  Kind kind = Kind::kPolyline;
  std::vector<Vec2> points;  // polyline vertices; circle centre / text anchor = points[0]
  Rgb stroke;
  double width_px = 1.0;
  bool filled = false;  // circle: filled with `fill`, else hollow (white inside)
  Rgb fill;
  double radius_px = 0;
  std::string text;
  double font_px = 12;
  std::string css_class;  // SVG class attribute, e.g. "segment both-real"
};

struct Drawing {
  int width = 0;
  int height = 0;
  std::vector<DrawItem> items;
  double pixels_per_metre = 1;
};

// A black text item anchored at its left end (the SVG and PNG back ends draw it alike).
DrawItem TextItem(Vec2 at, std::string text, double font_px, std::string css_class = "");

Drawing LayoutScene(const MapScene& scene, const RenderOptions& options = {});

// A "nice" scale bar length (1, 2 or 5 times a power of ten) close to `target_m`.
double NiceLength(double target_m);

std::string DrawingToSvg(const Drawing& drawing);
cv::Mat DrawingToImage(const Drawing& drawing);  // 8-bit BGR, anti-aliased, white background

std::string RenderSvg(const MapScene& scene, const RenderOptions& options = {});
cv::Mat RenderImage(const MapScene& scene, const RenderOptions& options = {});

// Writes a drawing as SVG to `svg_path` and as PNG to `png_path`: PermissionDenied if a file
// cannot be opened or written, DataLoss if writing the SVG fails, Internal on an OpenCV error.
absl::Status WriteDrawing(const Drawing& drawing, const std::filesystem::path& svg_path,
                          const std::filesystem::path& png_path);
// One of the two, with the same errors.
absl::Status WriteDrawingSvg(const Drawing& drawing, const std::filesystem::path& svg_path);
absl::Status WriteDrawingPng(const Drawing& drawing, const std::filesystem::path& png_path);

// Writes both pictures from one layout.
absl::Status WriteMapPictures(const MapScene& scene, const std::filesystem::path& svg_path,
                              const std::filesystem::path& png_path,
                              const RenderOptions& options = {});

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_MAP_RENDER_H_
