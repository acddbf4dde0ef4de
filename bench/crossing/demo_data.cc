// waymark-demo-data OUT_DIR: a ready-made crossing database and query set for trying Waymark
// without a robot, cut from the real 360-degree photos of the Debian package blender-data.
//
//   OUT_DIR/db/<place>/<heading>.jpg      12 views per place at 0, 30, ..., 330 degrees
//   OUT_DIR/query/<place>/<heading>.jpg   the same places seen 12 degrees off (file stem = true
//                                         heading, so `waymark eval` reports heading errors)
//   OUT_DIR/query/unknown/<place>-<h>.jpg places that are not in the database

#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "bench/crossing/rotation_set.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: waymark-demo-data OUT_DIR\n";
    return 2;
  }
  namespace fs = std::filesystem;
  using waymark::bench::FindPanoramas;
  const fs::path out = argv[1];
  const auto sources = FindPanoramas();
  if (sources.size() < 3) {
    std::cerr << "need the 360-degree photos of the Debian package "
              << waymark::bench::kPanoramaPackage
              << ": run scripts/install-deps.sh (as root)\n";
    return 1;
  }
  const size_t unknown_from = sources.size() - 2;  // the last two places stay out of the database
  for (size_t p = 0; p < sources.size(); ++p) {
    auto panorama = waymark::bench::LoadPanorama(sources[p]);
    if (!panorama.ok()) {
      std::cerr << sources[p].name << ": " << panorama.status() << "\n";
      return 1;
    }
    const std::string place = fs::path(sources[p].name).filename().string();
    for (int k = 0; k < 12; ++k) {
      const double stored = 30.0 * k, query = stored + 12;
      auto write = [&](const fs::path& file, double heading) {
        fs::create_directories(file.parent_path());
        auto view = waymark::bench::RenderView(*panorama, heading);
        return view.ok() && cv::imwrite(file.string(), *view, {cv::IMWRITE_JPEG_QUALITY, 92});
      };
      bool ok;
      if (p < unknown_from) {
        ok = write(out / "db" / place / fmt::format("{:03.0f}.jpg", stored), stored) &&
             write(out / "query" / place / fmt::format("{:03.0f}.jpg", query), query);
      } else {
        ok = write(out / "query" / "unknown" / fmt::format("{}-{:03.0f}.jpg", place, query), query);
      }
      if (!ok) {
        std::cerr << "cannot write views of " << place << " under " << out << "\n";
        return 1;
      }
    }
    std::cerr << (p < unknown_from ? "place " : "unknown place ") << place << ": "
              << sources[p].description << "\n";
  }
  std::cout << fmt::format("wrote {}/db ({} places x 12 views) and {}/query\n", out.string(),
                           unknown_from, out.string());
  return 0;
}
