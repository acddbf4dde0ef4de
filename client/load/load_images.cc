#include "client/load/load_images.h"

#include "absl/strings/str_cat.h"
#include "client/sim/sim_scene.h"
#include "client/datasets/image_folder.h"
#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

constexpr int kCrossings = 4;
constexpr int kUnknownPlaces = 2;
constexpr int kViewsPerCrossing = 12;
constexpr uint32_t kSeed = 7001;  // any fixed seed: runs are comparable with each other

}  // namespace

LoadImages GeneratedLoadImages() {
  LoadImages images;
  for (int c = 0; c < kCrossings + kUnknownPlaces; ++c) {
    const cv::Mat panorama = adapters::MakePanorama(kSeed + c);
    const bool enrolled = c < kCrossings;
    for (int k = 0; k < kViewsPerCrossing; ++k) {
      const double heading = 360.0 * k / kViewsPerCrossing;
      if (enrolled) {
        images.views.push_back({absl::StrCat("bench-", c), heading,
                                adapters::EncodeJpeg(adapters::CropView(panorama, heading))});
      }
      // Every other gap between enrolled headings for the enrolled places, fewer unknown ones.
      if (k % (enrolled ? 2 : 6) == 0) {
        images.queries.push_back(adapters::EncodeJpeg(
            adapters::CropView(panorama, heading + 180.0 / kViewsPerCrossing)));
      }
    }
  }
  return images;
}

absl::StatusOr<LoadImages> FolderLoadImages(const std::filesystem::path& dir) {
  absl::StatusOr<std::vector<EnrollImage>> found = ScanEnrollFolder(dir);
  if (!found.ok()) return found.status();  // an empty folder included
  LoadImages images;
  for (const EnrollImage& image : *found) {
    absl::StatusOr<std::string> bytes = ReadFileBytes(image.path);
    if (!bytes.ok()) return bytes.status();
    images.queries.push_back(*bytes);
    images.views.push_back({image.crossing, image.heading_deg, *std::move(bytes)});
  }
  return images;
}

}  // namespace waymark::cli
