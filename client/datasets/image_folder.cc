#include "client/datasets/image_folder.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <map>
#include <set>
#include <system_error>
#include <tuple>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;

// Headings have at most this many digits before the decimal point: 0 to 359.
constexpr size_t kMaxHeadingDigits = 3;
// Layout problems listed in one error; the rest are counted.
constexpr size_t kMaxProblemsListed = 10;

bool IsHidden(const fs::path& path) { return path.filename().string().rfind('.', 0) == 0; }

bool IsVisibleImage(const fs::directory_entry& entry) {
  return !IsHidden(entry.path()) && entry.is_regular_file() && IsImageFile(entry.path());
}

// A folder in messages: "DIR/a/b/".
std::string FolderName(const fs::path& folder) { return folder.string() + "/"; }

// An image found in a first-level folder of a scanned folder, or in a position folder inside one.
struct FoundImage {
  std::string folder;
  fs::path path;
  std::string position;  // the position folder's name; empty for an image directly in `folder`
};

// Whether a walk takes DIR/<folder>/<position>/ as a place for images (enrollment) or not.
enum class PositionFolders { kNo, kYes };

// Where a scan found images: directly in DIR, in DIR/<folder>/ (and DIR/<folder>/<position>/ with
// PositionFolders::kYes) where the layouts want them, and the folders below those that hold images
// (too deep).
struct FolderWalk {
  std::vector<fs::path> top;
  std::vector<FoundImage> images;
  std::set<fs::path> too_deep;
};

// The folders under `folder` (at any depth) that hold images.
void CollectImageFolders(const fs::path& folder, std::set<fs::path>* out) {
  for (auto it = fs::recursive_directory_iterator(folder); it != fs::recursive_directory_iterator();
       ++it) {
    if (IsHidden(it->path())) {
      if (it->is_directory()) it.disable_recursion_pending();
      continue;
    }
    if (IsVisibleImage(*it)) out->insert(it->path().parent_path());
  }
}

// The images directly in `folder` (a position folder of crossing `crossing`) into `walk`, and its
// sub-folders that hold images into its too-deep list.
void WalkPositionFolder(const fs::path& folder, const std::string& crossing, FolderWalk* walk) {
  const std::string position = folder.filename().string();
  for (const fs::directory_entry& file : fs::directory_iterator(folder)) {
    if (IsVisibleImage(file)) {
      walk->images.push_back({crossing, file.path(), position});
    } else if (file.is_directory() && !IsHidden(file.path())) {
      CollectImageFolders(file.path(), &walk->too_deep);
    }
  }
}

absl::StatusOr<FolderWalk> WalkFolder(const fs::path& dir,
                                      PositionFolders positions = PositionFolders::kNo) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat("'", dir.string(), "' is not a directory"));
  }
  FolderWalk walk;
  try {
    for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
      if (IsHidden(entry.path())) continue;
      if (!entry.is_directory()) {
        if (IsVisibleImage(entry)) walk.top.push_back(entry.path());
        continue;
      }
      const std::string folder = entry.path().filename().string();
      for (const fs::directory_entry& file : fs::directory_iterator(entry.path())) {
        if (IsVisibleImage(file)) {
          walk.images.push_back({folder, file.path(), ""});
        } else if (file.is_directory() && !IsHidden(file.path())) {
          if (positions == PositionFolders::kYes) {
            WalkPositionFolder(file.path(), folder, &walk);
          } else {
            CollectImageFolders(file.path(), &walk.too_deep);
          }
        }
      }
    }
  } catch (const fs::filesystem_error& e) {
    return absl::PermissionDeniedError(
        absl::StrCat("cannot read '", dir.string(), "': ", e.what()));
  }
  // Sorted, so that messages list files in the same order on every run and file system.
  std::sort(walk.top.begin(), walk.top.end());
  std::sort(walk.images.begin(), walk.images.end(),
            [](const FoundImage& a, const FoundImage& b) { return a.path < b.path; });
  return walk;
}

// The problems of a walk that no layout of DIR/<folder>/<file> (or, with PositionFolders::kYes,
// DIR/<folder>/<position>/<file>) accepts.
std::vector<std::string> DepthProblems(const fs::path& dir, const FolderWalk& walk,
                                       PositionFolders positions = PositionFolders::kNo) {
  std::vector<std::string> problems;
  if (!walk.top.empty()) {
    problems.push_back(absl::StrCat(
        "found ", walk.top.size(), " image(s) directly in ", FolderName(dir), " (e.g. ",
        walk.top.front().string(), "): one level too shallow? each crossing's images go in a "
        "folder of their own, ", FolderName(dir / "<crossing>")));
  }
  for (const fs::path& folder : walk.too_deep) {
    problems.push_back(absl::StrCat(
        "found images in ", FolderName(folder), ": one level too deep? ",
        positions == PositionFolders::kYes
            ? absl::StrCat("images go in a crossing folder or in its position folders, ",
                           FolderName(dir / "<crossing>" / "<position>"))
            : absl::StrCat("crossing folders go directly in ", FolderName(dir))));
  }
  return problems;
}

// INVALID_ARGUMENT listing `problems` (the first kMaxProblemsListed) under what was expected.
absl::Status LayoutError(const fs::path& dir, const std::string& expected,
                         const std::vector<std::string>& problems) {
  std::string message = absl::StrCat("'", dir.string(), "' is not laid out as ", expected, ":");
  for (size_t i = 0; i < problems.size() && i < kMaxProblemsListed; ++i) {
    absl::StrAppend(&message, "\n  ", problems[i]);
  }
  if (problems.size() > kMaxProblemsListed) {
    absl::StrAppend(&message, "\n  ... and ", problems.size() - kMaxProblemsListed, " more");
  }
  return absl::InvalidArgumentError(message);
}

absl::Status NoImagesError(const fs::path& dir, const std::string& expected) {
  return absl::InvalidArgumentError(absl::StrCat("no .jpg/.jpeg/.png images found in ",
                                                 FolderName(dir / "<folder>"), "; expected ",
                                                 expected));
}

bool IsDigit(char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }

// The crossing folders that hold both images and position folders of images: which layout they
// follow is not clear (a stray image, or a position folder created by mistake), so each is named
// with an example of either kind.
std::vector<std::string> MixedCrossingFolders(const fs::path& dir,
                                              const std::vector<FoundImage>& images) {
  struct Kinds {
    const FoundImage* direct = nullptr;
    const FoundImage* positioned = nullptr;
  };
  std::map<std::string, Kinds> crossings;
  for (const FoundImage& image : images) {
    Kinds& kinds = crossings[image.folder];
    const FoundImage*& first = image.position.empty() ? kinds.direct : kinds.positioned;
    if (first == nullptr) first = &image;
  }
  std::vector<std::string> problems;
  for (const auto& [crossing, kinds] : crossings) {
    if (kinds.direct == nullptr || kinds.positioned == nullptr) continue;
    problems.push_back(absl::StrCat(
        FolderName(dir / crossing), " holds both images (e.g. ", kinds.direct->path.string(),
        ") and position folders (e.g. ", FolderName(kinds.positioned->path.parent_path()),
        "): put all of a crossing's views in position folders, or none"));
  }
  return problems;
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
  // digits ['.' digits]: checked by hand, because strtod and from_chars accept more (signs,
  // exponents, "inf") than a heading file name may hold.
  size_t end = 0;
  while (end < stem.size() && IsDigit(stem[end])) ++end;
  const size_t integer_digits = end;
  bool is_number = integer_digits > 0;
  if (end < stem.size() && stem[end] == '.') {
    const size_t fraction_start = ++end;
    while (end < stem.size() && IsDigit(stem[end])) ++end;
    is_number = is_number && end > fraction_start;
  }
  is_number = is_number && end == stem.size();
  if (!is_number) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", file.string(), "': '", stem, "' is not a heading; name each view by its compass "
        "heading in degrees, e.g. 030.jpg or 30.5.png"));
  }
  if (integer_digits > kMaxHeadingDigits) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", file.string(), "': '", stem, "' has ", integer_digits, " digits before the decimal "
        "point, a heading at most ", kMaxHeadingDigits, " (a frame number? headings are degrees "
        "in [0, 360), e.g. 030.jpg)"));
  }
  double value = 0;
  std::from_chars(stem.data(), stem.data() + stem.size(), value);
  if (value >= 360) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", file.string(), "': heading ", stem, " is outside [0, 360); headings are not wrapped "
        "(400 is not 40 degrees)"));
  }
  return value;
}

absl::StatusOr<std::vector<EnrollImage>> ScanEnrollFolder(const fs::path& dir) {
  absl::StatusOr<FolderWalk> walk = WalkFolder(dir, PositionFolders::kYes);
  if (!walk.ok()) return walk.status();
  std::vector<std::string> problems = DepthProblems(dir, *walk, PositionFolders::kYes);
  for (std::string& problem : MixedCrossingFolders(dir, walk->images)) {
    problems.push_back(std::move(problem));
  }
  std::vector<EnrollImage> images;
  images.reserve(walk->images.size());
  for (FoundImage& image : walk->images) {
    absl::StatusOr<double> heading = ParseHeading(image.path);
    if (!heading.ok()) {
      problems.emplace_back(heading.status().message());
      continue;
    }
    images.push_back({std::move(image.folder), *heading, std::move(image.path),
                      std::move(image.position), ""});
  }
  std::sort(images.begin(), images.end(), [](const EnrollImage& a, const EnrollImage& b) {
    return std::tie(a.crossing, a.position, a.heading_deg, a.path) <
           std::tie(b.crossing, b.position, b.heading_deg, b.path);
  });
  // One image per heading (and position): a second one is a stray copy (030.jpg beside 30.png),
  // and `enroll --replace` would let the later replace the earlier.
  for (size_t i = 1; i < images.size(); ++i) {
    if (images[i].crossing == images[i - 1].crossing &&
        images[i].position == images[i - 1].position &&
        images[i].heading_deg == images[i - 1].heading_deg) {
      problems.push_back(absl::StrCat("'", images[i - 1].path.string(), "' and '",
                                      images[i].path.string(), "' both have heading ",
                                      images[i].heading_deg, ": keep one image per heading"));
    }
  }
  if (!problems.empty()) return LayoutError(dir, kEnrollLayout, problems);
  if (images.empty()) return NoImagesError(dir, kEnrollLayout);
  return images;
}

absl::StatusOr<std::vector<QueryImage>> ScanQueryFolder(const fs::path& dir) {
  static const std::string kQueryLayout = absl::StrCat(
      "DIR/<crossing>/<file>.jpg (or .jpeg, .png), one folder per crossing plus DIR/",
      kUnknownFolder, "/ for places not in the database");
  absl::StatusOr<FolderWalk> walk = WalkFolder(dir);
  if (!walk.ok()) return walk.status();
  if (std::vector<std::string> problems = DepthProblems(dir, *walk); !problems.empty()) {
    return LayoutError(dir, kQueryLayout, problems);
  }
  if (walk->images.empty()) return NoImagesError(dir, kQueryLayout);
  std::vector<QueryImage> queries;
  queries.reserve(walk->images.size());
  for (FoundImage& image : walk->images) {
    absl::StatusOr<double> heading = ParseHeading(image.path);
    queries.push_back({std::move(image.folder), std::move(image.path),
                       heading.ok() ? std::optional<double>(*heading) : std::nullopt});
  }
  std::sort(queries.begin(), queries.end(), [](const QueryImage& a, const QueryImage& b) {
    return std::tie(a.folder, a.path) < std::tie(b.folder, b.path);
  });
  return queries;
}

absl::StatusOr<std::vector<fs::path>> ListFolderImages(const fs::path& dir) {
  absl::StatusOr<FolderWalk> walk = WalkFolder(dir);
  if (!walk.ok()) return walk.status();
  if (!walk->top.empty()) return walk->top;
  std::set<fs::path> folders = walk->too_deep;
  for (const FoundImage& image : walk->images) folders.insert(image.path.parent_path());
  if (folders.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("no .jpg/.jpeg/.png images found in ", FolderName(dir)));
  }
  std::vector<std::string> names;
  for (const fs::path& folder : folders) {
    if (names.size() == 3) break;
    names.push_back(FolderName(folder));
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "no .jpg/.jpeg/.png images directly in ", FolderName(dir), "; found images in ",
      absl::StrJoin(names, ", "), folders.size() > names.size() ? " and more" : "",
      ": give one of those folders, or use `waymark eval NAME DIR` for a folder of crossing "
      "folders"));
}

}  // namespace waymark::cli
