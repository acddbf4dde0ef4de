#include "bench/crossing/rotation_set.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace waymark::bench {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

// Elevation limits accepted for a panorama's edges (a cylindrical image cannot reach +-90).
bool ValidGeometry(VerticalProjection projection, double top_deg, double bottom_deg) {
  if (!(top_deg > bottom_deg) || top_deg > 90 || bottom_deg < -90) return false;
  if (projection == VerticalProjection::kCylindrical) return top_deg < 89 && bottom_deg > -89;
  return projection == VerticalProjection::kEquirectangular;
}

// Global Reinhard tone mapping of a float BGR image to 8-bit BGR (see LoadPanorama).
cv::Mat ToneMap(const cv::Mat& hdr) {
  cv::Mat bgr;
  hdr.convertTo(bgr, CV_32FC3);
  bgr = cv::max(bgr, 0.0);
  cv::Mat luminance;
  cv::cvtColor(bgr, luminance, cv::COLOR_BGR2GRAY);
  cv::Mat log_l;
  cv::log(cv::max(luminance, 1e-4), log_l);
  const double log_average = std::exp(cv::mean(log_l)[0]);
  bgr *= 0.18 / log_average;
  cv::Mat mapped;
  cv::divide(bgr, bgr + cv::Scalar::all(1.0), mapped);
  cv::pow(mapped, 1.0 / 2.2, mapped);
  cv::Mat out;
  mapped.convertTo(out, CV_8UC3, 255.0);
  return out;
}

// Any supported image to 8-bit BGR: alpha over kFillBgr, HDR tone-mapped, gray expanded.
absl::StatusOr<cv::Mat> ToBgr8(const cv::Mat& image) {
  if (image.empty()) return absl::InvalidArgumentError("empty image");
  const int depth = image.depth();
  if (depth == CV_32F || depth == CV_64F) {
    cv::Mat bgr;
    if (image.channels() == 1) {
      cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    } else if (image.channels() == 4) {
      cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
    } else {
      bgr = image;
    }
    return ToneMap(bgr);
  }
  cv::Mat image8;
  if (depth == CV_16U) {
    image.convertTo(image8, CV_MAKETYPE(CV_8U, image.channels()), 1.0 / 257.0);
  } else if (depth == CV_8U) {
    image8 = image;
  } else {
    return absl::InvalidArgumentError(absl::StrCat("unsupported pixel depth ", depth));
  }
  cv::Mat bgr;
  switch (image8.channels()) {
    case 1:
      cv::cvtColor(image8, bgr, cv::COLOR_GRAY2BGR);
      return bgr;
    case 3:
      return image8.clone();
    case 4: {
      // out = alpha * colour + (1 - alpha) * fill
      cv::Mat colour, alpha;
      cv::cvtColor(image8, colour, cv::COLOR_BGRA2BGR);
      cv::extractChannel(image8, alpha, 3);
      cv::Mat colour_f, alpha_f, alpha3;
      colour.convertTo(colour_f, CV_32FC3);
      alpha.convertTo(alpha_f, CV_32F, 1.0 / 255.0);
      cv::merge(std::vector<cv::Mat>{alpha_f, alpha_f, alpha_f}, alpha3);
      cv::Mat fill(colour_f.size(), CV_32FC3, kFillBgr);
      cv::Mat blended = colour_f.mul(alpha3) + fill.mul(cv::Scalar::all(1.0) - alpha3);
      blended.convertTo(bgr, CV_8UC3);
      return bgr;
    }
    default:
      return absl::InvalidArgumentError(absl::StrCat(image8.channels(), " channels"));
  }
}

// Row coordinate (in pixels, 0 = top edge) of elevation `elev` (radians).
double RowOf(double elev, const Panorama& p, int rows) {
  if (p.projection == VerticalProjection::kCylindrical) {
    const double top = std::tan(p.top_deg * kDegToRad);
    const double bottom = std::tan(p.bottom_deg * kDegToRad);
    return (top - std::tan(elev)) / (top - bottom) * rows;
  }
  const double top = p.top_deg * kDegToRad;
  const double bottom = p.bottom_deg * kDegToRad;
  return (top - elev) / (top - bottom) * rows;
}

// --- Finding panoramas ---

struct BlenderWorld {
  const char* file;
  const char* description;
};
// The real-photo worlds of blender-data: 1024x512 equirectangular HDR photos by Greg Zaal (HDRI
// Haven), CC0 (license.txt beside them). studio.exr, an almost textureless photo studio, is left
// out. Order = crossing ids in the evaluation.
constexpr BlenderWorld kBlenderWorlds[] = {
    {"city", "office towers around a car park"},
    {"courtyard", "covered courtyard of a house: walls, windows, kennels, a garage"},
    {"forest", "garden path between trees, a fence and rocks"},
    {"interior", "hotel room"},
    {"night", "field at night, trees and lit houses on the horizon"},
    {"sunrise", "meadow with trees and power pylons at sunrise"},
    {"sunset", "waterfront promenade with buildings, open sea on one side, at sunset"},
};

// Minimal INI reader for Stellarium's landscape.ini: section/key -> value.
std::map<std::string, std::string> ReadIni(const std::filesystem::path& file) {
  std::map<std::string, std::string> values;
  std::ifstream in(file);
  std::string line, section;
  auto trim = [](std::string s) {
    const char* ws = " \t\r\n";
    s.erase(0, s.find_first_not_of(ws));
    const size_t end = s.find_last_not_of(ws);
    s.erase(end == std::string::npos ? 0 : end + 1);
    return s;
  };
  while (std::getline(in, line)) {
    line = trim(line);
    if (line.empty() || line[0] == ';' || line[0] == '#') continue;
    if (line[0] == '[') {
      section = trim(line.substr(1, line.find(']') - 1));
      continue;
    }
    const size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    values[section + "/" + trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  return values;
}

double NumberOr(const std::map<std::string, std::string>& ini, const std::string& key,
                double fallback) {
  auto it = ini.find(key);
  if (it == ini.end()) return fallback;
  try {
    return std::stod(it->second);
  } catch (...) {
    return fallback;
  }
}

// Stellarium landscapes that are real photos of a place with texture (fields, trees, houses).
// Geometry read from landscape.ini: "spherical" = equirectangular between maptex_top and
// maptex_bottom (default 90 / -90); "old_style" = the side textures joined left to right, rows
// from decor_angle_shift + decor_alt_angle (top) down to decor_angle_shift (bottom), linear in
// elevation, or in tan(elevation) with tan_mode (an approximation of how Stellarium draws them).
void AddStellarium(const std::filesystem::path& landscapes, std::vector<PanoramaSource>* out) {
  namespace fs = std::filesystem;
  for (const char* id : {"guereins", "garching", "hurricane", "grossmugl"}) {
    const fs::path dir = landscapes / id;
    std::error_code ec;
    if (!fs::exists(dir / "landscape.ini", ec)) continue;
    const auto ini = ReadIni(dir / "landscape.ini");
    auto get = [&](const std::string& key) {
      auto it = ini.find("landscape/" + key);
      return it == ini.end() ? std::string() : it->second;
    };
    PanoramaSource s;
    s.name = absl::StrCat("stellarium/", id);
    s.package = "stellarium-data";
    s.description = get("description");
    const std::string type = get("type");
    if (type == "spherical") {
      s.tiles.push_back((dir / get("maptex")).string());
      s.top_deg = NumberOr(ini, "landscape/maptex_top", 90);
      s.bottom_deg = NumberOr(ini, "landscape/maptex_bottom", -90);
    } else if (type == "old_style") {
      const int sides = static_cast<int>(NumberOr(ini, "landscape/nbside", 0));
      for (int i = 0; i < sides; ++i) {
        // sideN = texK:x0:y0:x1:y1
        const std::string side = get(absl::StrCat("side", i));
        const std::string tex = get(side.substr(0, side.find(':')));
        if (tex.empty()) break;
        s.tiles.push_back((dir / tex).string());
      }
      if (static_cast<int>(s.tiles.size()) != sides || sides == 0) continue;
      const double shift = NumberOr(ini, "landscape/decor_angle_shift", 0);
      const double span = NumberOr(ini, "landscape/decor_alt_angle", 0);
      s.bottom_deg = shift;
      s.top_deg = shift + span;
      if (get("tan_mode") == "true") s.projection = VerticalProjection::kCylindrical;
    } else {
      continue;
    }
    bool files_ok = ValidGeometry(s.projection, s.top_deg, s.bottom_deg);
    for (const std::string& t : s.tiles) files_ok = files_ok && fs::exists(t, ec);
    if (files_ok) out->push_back(std::move(s));
  }
}

}  // namespace

absl::StatusOr<Panorama> MakePanorama(const std::string& name, const cv::Mat& image,
                                      VerticalProjection projection, double top_deg,
                                      double bottom_deg) {
  if (!ValidGeometry(projection, top_deg, bottom_deg)) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": bad vertical geometry (top ", top_deg, ", bottom ", bottom_deg, ")"));
  }
  absl::StatusOr<cv::Mat> bgr;
  try {
    bgr = ToBgr8(image);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": ", e.what()));
  }
  if (!bgr.ok())
    return absl::InvalidArgumentError(absl::StrCat(name, ": ", bgr.status().message()));
  if (bgr->cols < 8 || bgr->rows < 8) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": panorama smaller than 8x8"));
  }
  Panorama p;
  p.name = name;
  p.bgr = *std::move(bgr);
  p.projection = projection;
  p.top_deg = top_deg;
  p.bottom_deg = bottom_deg;
  return p;
}

absl::StatusOr<Panorama> LoadPanorama(const PanoramaSource& source) {
  if (source.tiles.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(source.name, ": no image files"));
  }
  std::vector<cv::Mat> tiles;
  for (const std::string& file : source.tiles) {
    cv::Mat tile;
    try {
      tile = cv::imread(file, cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception& e) {
      return absl::NotFoundError(absl::StrCat(file, ": ", e.what()));
    }
    if (tile.empty()) {
      return absl::NotFoundError(
          absl::StrCat(file,
                       ": missing or unreadable (for .exr files OpenCV may need "
                       "OPENCV_IO_ENABLE_OPENEXR=1 in the environment)"));
    }
    absl::StatusOr<cv::Mat> bgr;
    try {
      bgr = ToBgr8(tile);
    } catch (const cv::Exception& e) {
      return absl::InvalidArgumentError(absl::StrCat(file, ": ", e.what()));
    }
    if (!bgr.ok())
      return absl::InvalidArgumentError(absl::StrCat(file, ": ", bgr.status().message()));
    if (!tiles.empty() && bgr->rows != tiles.front().rows) {
      return absl::InvalidArgumentError(absl::StrCat(file, ": height ", bgr->rows, " differs from ",
                                                     tiles.front().rows, " of the first tile"));
    }
    tiles.push_back(*std::move(bgr));
  }
  cv::Mat joined;
  cv::hconcat(tiles, joined);
  return MakePanorama(source.name, joined, source.projection, source.top_deg, source.bottom_deg);
}

double FocalLengthPx(const ViewOptions& options) {
  return 0.5 * options.width / std::tan(0.5 * options.hfov_deg * kDegToRad);
}

absl::StatusOr<cv::Mat> RenderView(const Panorama& panorama, double heading_deg,
                                   const ViewOptions& options) {
  if (!(options.hfov_deg > 0 && options.hfov_deg < 180)) {
    return absl::InvalidArgumentError(
        absl::StrCat("horizontal field of view ", options.hfov_deg, " outside (0, 180) degrees"));
  }
  if (options.width < 8 || options.height < 8) {
    return absl::InvalidArgumentError("view smaller than 8x8");
  }
  if (panorama.bgr.empty() || !std::isfinite(heading_deg)) {
    return absl::InvalidArgumentError("empty panorama or non-finite heading");
  }
  const double f = FocalLengthPx(options);
  try {
    // Shrink a panorama finer than the view's centre (2*pi*f columns for 360 degrees): remap's
    // bilinear sampling alone would alias.
    cv::Mat source = panorama.bgr;
    const int matched_width = static_cast<int>(std::ceil(2 * kPi * f));
    if (source.cols > 1.25 * matched_width) {
      const int rows = std::max(
          8, static_cast<int>(std::lround(double(source.rows) * matched_width / source.cols)));
      cv::resize(source, source, cv::Size(matched_width, rows), 0, 0, cv::INTER_AREA);
    }
    const int cols = source.cols;
    const int rows = source.rows;
    // Wrap a few columns around so bilinear sampling across the 0/360 seam needs no special case.
    constexpr int kPad = 2;
    cv::Mat padded;
    cv::copyMakeBorder(source, padded, 0, 0, kPad, kPad, cv::BORDER_WRAP);

    const double heading = std::fmod(std::fmod(heading_deg, 360.0) + 360.0, 360.0) * kDegToRad;
    const double cx = 0.5 * options.width;
    const double cy = 0.5 * options.height;
    cv::Mat map_x(options.height, options.width, CV_32F);
    cv::Mat map_y(options.height, options.width, CV_32F);
    for (int v = 0; v < options.height; ++v) {
      float* mx = map_x.ptr<float>(v);
      float* my = map_y.ptr<float>(v);
      const double y = (v + 0.5 - cy) / f;  // down
      for (int u = 0; u < options.width; ++u) {
        const double x = (u + 0.5 - cx) / f;  // right; the optical axis is z = 1
        const double azimuth = heading + std::atan2(x, 1.0);
        const double elevation = std::atan2(-y, std::hypot(x, 1.0));
        double col = azimuth / (2 * kPi) * cols;
        col = std::fmod(std::fmod(col, cols) + cols, cols);
        // Pixel centres sit at integer + 0.5 in edge coordinates.
        mx[u] = static_cast<float>(col - 0.5 + kPad);
        my[u] = static_cast<float>(RowOf(elevation, panorama, rows) - 0.5);
      }
    }
    cv::Mat view;
    cv::remap(padded, view, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, kFillBgr);
    return view;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("rendering the view failed: ", e.what()));
  }
}

std::vector<PanoramaSource> FindPanoramas(const std::string& root) {
  namespace fs = std::filesystem;
  std::vector<PanoramaSource> out;
  const fs::path base = fs::path(root.empty() ? "/" : root);
  const fs::path worlds = base / "usr/share/blender/datafiles/studiolights/world";
  std::error_code ec;
  for (const BlenderWorld& w : kBlenderWorlds) {
    const fs::path file = worlds / (std::string(w.file) + ".exr");
    if (!fs::exists(file, ec)) continue;
    PanoramaSource s;
    s.name = absl::StrCat("blender/", w.file);
    s.tiles = {file.string()};
    s.description = w.description;
    s.package = kPanoramaPackage;
    out.push_back(std::move(s));
  }
  AddStellarium(base / "usr/share/stellarium/landscapes", &out);
  return out;
}

}  // namespace waymark::bench
