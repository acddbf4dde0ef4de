#include "client/datasets/image_folder.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <system_error>
#include <tuple>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;

bool IsHidden(const fs::path& path) { return path.filename().string().rfind('.', 0) == 0; }

// An image found under a scanned folder: its first-level folder name and path.
struct FoundImage {
  std::string folder;
  fs::path path;
};

// Walks dir/<folder>/<file>, one level deep, collecting image files.
absl::StatusOr<std::vector<FoundImage>> FindImages(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat("'", dir.string(), "' is not a directory"));
  }
  std::vector<FoundImage> found;
  try {
    for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
      if (IsHidden(entry.path())) continue;
      if (!entry.is_directory()) {
        if (IsImageFile(entry.path())) {
          return absl::InvalidArgumentError(
              absl::StrCat("image '", entry.path().string(),
                           "' is not inside a folder; expected DIR/<crossing>/<file>"));
        }
        continue;
      }
      const std::string folder = entry.path().filename().string();
      for (const fs::directory_entry& file : fs::directory_iterator(entry.path())) {
        if (!IsHidden(file.path()) && file.is_regular_file() && IsImageFile(file.path())) {
          found.push_back({folder, file.path()});
        }
      }
    }
  } catch (const fs::filesystem_error& e) {
    return absl::PermissionDeniedError(
        absl::StrCat("cannot read '", dir.string(), "': ", e.what()));
  }
  if (found.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("no .jpg/.jpeg/.png images found in '", dir.string(), "/<folder>/'"));
  }
  return found;
}

}  // namespace

bool IsImageFile(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png";
}

absl::StatusOr<double> ParseHeading(const fs::path& file) {
  const std::string stem = file.stem().string();
  double value = 0;
  // from_chars, unlike strtod, accepts no leading spaces, '+', hex or "inf"-style words.
  const auto [end, ec] = std::from_chars(stem.data(), stem.data() + stem.size(), value);
  if (stem.empty() || ec != std::errc() || end != stem.data() + stem.size() ||
      !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read a heading from '", file.string(),
                     "': the file name must be the heading in degrees, e.g. 030.jpg or 30.5.png"));
  }
  value = std::fmod(value, 360.0);
  if (value < 0) value += 360.0;
  return value;
}

absl::StatusOr<std::vector<EnrollImage>> ScanEnrollFolder(const fs::path& dir) {
  absl::StatusOr<std::vector<FoundImage>> found = FindImages(dir);
  if (!found.ok()) return found.status();
  std::vector<EnrollImage> images;
  images.reserve(found->size());
  for (FoundImage& image : *found) {
    absl::StatusOr<double> heading = ParseHeading(image.path);
    if (!heading.ok()) return heading.status();
    images.push_back({std::move(image.folder), *heading, std::move(image.path)});
  }
  std::sort(images.begin(), images.end(), [](const EnrollImage& a, const EnrollImage& b) {
    return std::tie(a.crossing, a.heading_deg, a.path) <
           std::tie(b.crossing, b.heading_deg, b.path);
  });
  return images;
}

absl::StatusOr<std::vector<QueryImage>> ScanQueryFolder(const fs::path& dir) {
  absl::StatusOr<std::vector<FoundImage>> found = FindImages(dir);
  if (!found.ok()) return found.status();
  std::vector<QueryImage> queries;
  queries.reserve(found->size());
  for (FoundImage& image : *found) {
    absl::StatusOr<double> heading = ParseHeading(image.path);
    queries.push_back({std::move(image.folder), std::move(image.path),
                       heading.ok() ? std::optional<double>(*heading) : std::nullopt});
  }
  std::sort(queries.begin(), queries.end(), [](const QueryImage& a, const QueryImage& b) {
    return std::tie(a.folder, a.path) < std::tie(b.folder, b.path);
  });
  return queries;
}

}  // namespace waymark::cli
