#ifndef WAYMARK_CLIENT_RENDER_MAP_RENDER_H_
#define WAYMARK_CLIENT_RENDER_MAP_RENDER_H_

// Pictures of segment maps. One scene description (segments with endpoint types, polylines such as
// the trajectory, optional reference polylines, the current pose) is laid out once into a drawing
// in pixel coordinates (world y up, image y down; title, scale bar and legend placed there); the
// SVG and PNG back ends only serialise that drawing, so both pictures show the same geometry.
// Trajectories carry start and end markers, so a picture says which way the robot went; the title
// is shrunk or wrapped to the picture's width (text_fit.h).

#include <cstdint>
#include <filesystem>
#include <optional>
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
  // A trajectory: a hollow circle at its first point (start) and a filled square at its last
  // (end), in its colour. Walls and other non-paths have none.
  bool mark_ends = false;
};

// A pose drawn as an arrow pointing along the heading (the robot's current pose on a map).
struct ScenePose {
  Vec2 position;       // world metres
  double heading = 0;  // radians, counter-clockwise from the world x axis
  Rgb color;
  std::string label;  // legend entry; empty = none
};

struct MapScene {
  std::string title;
  std::vector<SceneSegment> segments;
  std::vector<ScenePolyline> polylines;   // drawn over the segments (e.g. the trajectory)
  std::vector<ScenePolyline> references;  // drawn under everything (e.g. a reference path)
  std::optional<ScenePose> current_pose;  // drawn over everything
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
  enum class Kind { kPolyline, kCircle, kText, kPolygon };
  Kind kind = Kind::kPolyline;
  // Polyline and polygon vertices (a polygon is closed and filled with `fill`); circle centre /
  // text anchor = points[0].
  std::vector<Vec2> points;
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

// A title in the band at the top of a drawing `width` pixels wide: at `font_px`, shrunk or
// wrapped to fit (text_fit.h), one text item per line with class `css_class`. Returns the band's
// height; the items go to `items`.
int LayoutTitle(const std::string& title, int width, double font_px, const std::string& css_class,
                std::vector<DrawItem>& items);

// Title band and font of map pictures (and the plots that share their look).
inline constexpr double kTitleFontPx = 14;

Drawing LayoutScene(const MapScene& scene, const RenderOptions& options = {});

// A "nice" scale bar length (1, 2 or 5 times a power of ten) close to `target_m`.
double NiceLength(double target_m);

std::string DrawingToSvg(const Drawing& drawing);
cv::Mat DrawingToImage(const Drawing& drawing);  // 8-bit BGR, anti-aliased, white background
// Draws `items` (pixel coordinates) onto an 8-bit BGR image, as DrawingToImage does on white.
void DrawItemsOn(const std::vector<DrawItem>& items, cv::Mat& image);
// A path in pixel coordinates as the map pictures draw a trajectory: the line, a hollow circle at
// its first point and a filled square at its last, in its colour.
std::vector<DrawItem> PathItems(const std::vector<Vec2>& points_px, Rgb color, double width_px);

std::string RenderSvg(const MapScene& scene, const RenderOptions& options = {});
cv::Mat RenderImage(const MapScene& scene, const RenderOptions& options = {});

// Writes a drawing as SVG to `svg_path` and as PNG to `png_path`: PermissionDenied if a file
// cannot be opened or written, DataLoss if writing the SVG fails, Internal on an OpenCV error.
absl::Status WriteDrawing(const Drawing& drawing, const std::filesystem::path& svg_path,
                          const std::filesystem::path& png_path);
// One of the two, chosen by the extension (.svg or .png, any case); INVALID_ARGUMENT for another.
absl::Status WriteDrawingFile(const Drawing& drawing, const std::filesystem::path& path);
// An image as PNG: PermissionDenied if it cannot be written, Internal on an OpenCV error.
absl::Status WritePngImage(const cv::Mat& image, const std::filesystem::path& path);

// Writes both pictures from one layout.
absl::Status WriteMapPictures(const MapScene& scene, const std::filesystem::path& svg_path,
                              const std::filesystem::path& png_path,
                              const RenderOptions& options = {});

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_RENDER_MAP_RENDER_H_
