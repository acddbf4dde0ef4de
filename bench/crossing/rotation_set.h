#ifndef WAYMARK_BENCH_CROSSING_ROTATION_SET_H_
#define WAYMARK_BENCH_CROSSING_ROTATION_SET_H_

// A rotation test set for crossing recognition (METHODS.md section 1: 12 views per crossing at
// 30-degree steps; the paper claims recognition 12 and 26 degrees off the stored headings).
// No public place-recognition set has 12 headings per place, so views are cut from real
// 360-degree photos shipped by a Debian package: every panorama stands for one crossing, and a
// pinhole camera turning on the spot is rendered from it at any heading.
//
// Geometry assumed for a panorama:
// - The image (one file, or several tiles joined left to right) covers exactly 360 degrees of
//   heading, linearly: the left edge of column 0 is heading 0, headings grow to the right, i.e.
//   clockwise seen from above (turning right moves the view right in the image), and the right
//   edge of the last column is heading 360 = 0 again.
// - Rows map to elevation between `top_deg` (top edge of row 0) and `bottom_deg` (bottom edge of
//   the last row), either linearly in elevation (kEquirectangular: a full spherical panorama has
//   top 90, bottom -90) or linearly in tan(elevation) (kCylindrical: the image on a cylinder
//   around the camera).
// - The camera is a distortion-free pinhole at the panorama's centre, pitch 0 and roll 0.
// Transparent pixels (a PNG's alpha, e.g. a masked-out sky) and directions outside the
// panorama's rows are filled with a neutral gray (no hue, so the hue histogram ignores them).
// HDR images (OpenEXR, Radiance) are tone-mapped to 8 bits once at load (see LoadPanorama).

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::bench {

enum class VerticalProjection {
  kEquirectangular = 1,  // row linear in elevation
  kCylindrical = 2,      // row linear in tan(elevation)
};

// Where a panorama's pixels come from and how they map to directions.
struct PanoramaSource {
  std::string name;                // short, unique: "blender/city"
  std::vector<std::string> tiles;  // image files joined left to right; together 360 degrees
  VerticalProjection projection = VerticalProjection::kEquirectangular;
  double top_deg = 90;      // elevation of the top edge
  double bottom_deg = -90;  // elevation of the bottom edge
  std::string description;  // what the photo shows (for reports)
  std::string package;      // Debian package that ships the files
};

struct Panorama {
  std::string name;
  cv::Mat bgr;  // 8-bit BGR, columns cover 360 degrees
  VerticalProjection projection = VerticalProjection::kEquirectangular;
  double top_deg = 90;
  double bottom_deg = -90;
};

// Gray used for transparent pixels and for directions outside the panorama.
inline const cv::Scalar kFillBgr(160, 160, 160);

// Reads and joins the tiles (all must have the same height). 8-bit images are used as they are
// (alpha composited over kFillBgr); float images (HDR) are tone-mapped with the global Reinhard
// operator L/(1+L) after scaling the log-average luminance to 0.18, then gamma 1/2.2.
// INVALID_ARGUMENT for bad geometry, NOT_FOUND for a missing or unreadable file.
absl::StatusOr<Panorama> LoadPanorama(const PanoramaSource& source);

// The same from an image already in memory (8-bit BGR or BGRA, or float BGR), for tests.
absl::StatusOr<Panorama> MakePanorama(
    const std::string& name, const cv::Mat& image,
    VerticalProjection projection = VerticalProjection::kEquirectangular, double top_deg = 90,
    double bottom_deg = -90);

struct ViewOptions {
  double hfov_deg = 60;  // horizontal field of view
  int width = 320;       // the paper's frame size
  int height = 240;
};

// Focal length in pixels of the pinhole camera: (width / 2) / tan(hfov / 2).
double FocalLengthPx(const ViewOptions& options);

// Renders the pinhole view looking at `heading_deg` (any real value; taken modulo 360) with pitch
// 0, with cv::remap (bilinear). When the panorama has a finer angular resolution than the view's
// centre, it is first shrunk (area averaging) so the view is not aliased. INVALID_ARGUMENT for a
// field of view outside (0, 180) or a size below 8x8.
absl::StatusOr<cv::Mat> RenderView(const Panorama& panorama, double heading_deg,
                                   const ViewOptions& options = {});

// The Debian package whose photos FindPanoramas looks for (installed by scripts/install-deps.sh).
inline constexpr char kPanoramaPackage[] = "blender-data";

// The usable panoramas found under `root` (normally "/"; a folder where a .deb was unpacked with
// dpkg -x works too): the real-photo equirectangular HDRIs of blender-data's
// usr/share/blender/datafiles/studiolights/world/ (Poly Haven photos, CC0), in a fixed order.
// Empty when the package is absent. Also lists the real-photo Stellarium landscapes when
// stellarium-data happens to be installed (not a project dependency).
std::vector<PanoramaSource> FindPanoramas(const std::string& root = "/");

}  // namespace waymark::bench

#endif  // WAYMARK_BENCH_CROSSING_ROTATION_SET_H_
