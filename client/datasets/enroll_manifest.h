#ifndef WAYMARK_CLIENT_DATASETS_ENROLL_MANIFEST_H_
#define WAYMARK_CLIENT_DATASETS_ENROLL_MANIFEST_H_

// `waymark enroll NAME --manifest FILE` (issue 34): views whose file names are not headings
// (`p0_i0.JPG`, `IMG_2041.jpg`), listed in a CSV file, one view per line:
//
//   file,crossing,heading,position
//   photos/p0_i0.JPG,main-and-1st,30,north-kerb
//   photos/p0_i1.JPG,main-and-1st,,            <- no heading: the view answers its crossing only
//   /data/night/0007.png,station,unknown
//
// - `file`: the image (.jpg, .jpeg or .png in any letter case), relative to the manifest's folder
//   or absolute.
// - `crossing`: the crossing's name (created when new).
// - `heading`: compass degrees in [0, 360), clockwise (any decimal number: 30, 030, 292.5); empty,
//   `unknown` or `-` for a view taken facing an unknown way. Such a view is stored with no
//   heading and a recognition that picks it names the crossing and no heading.
// - `position` (optional column): the capture position tag, as a position folder's name.
//
// The first line is a header when its first field is `file` (any letter case); fields may be
// quoted ("a, b" and "" for a quote inside); blank lines and lines starting with '#' are skipped.
// Views are enrolled in the manifest's order. Everything is checked before anything is sent and
// every problem is reported at once with its line: a missing or non-image file, an empty crossing,
// a heading that is not a number in [0, 360), too many fields, one file listed twice, two views
// of one crossing and position with the same (known) heading.

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/image_folder.h"

namespace waymark::cli {

// EnrollImage::heading_deg of a view with no heading.
inline constexpr double kUnknownHeading = std::numeric_limits<double>::quiet_NaN();
inline bool HasHeading(const EnrollImage& image) { return image.heading_deg == image.heading_deg; }

// The manifest's layout, for messages.
inline constexpr char kManifestLayout[] =
    "a CSV file with the columns file,crossing,heading[,position] (heading in degrees in "
    "[0, 360), or empty / unknown for none), e.g. photos/p0_i0.JPG,main-and-1st,30,north-kerb";

// The views `manifest` lists. NOT_FOUND when the manifest cannot be read; INVALID_ARGUMENT listing
// every problem (line numbers are 1-based lines of the file) or for a manifest with no view.
absl::StatusOr<std::vector<EnrollImage>> ReadEnrollManifest(const std::filesystem::path& manifest);

// The same from the manifest's text; files are resolved against `base` and checked to exist.
absl::StatusOr<std::vector<EnrollImage>> ParseEnrollManifest(const std::string& text,
                                                             const std::filesystem::path& base);

// DIR/<crossing>/<any name>.jpg, every view with no heading (`enroll NAME DIR --no-headings`):
// for folders whose file names are not headings. Images directly in DIR or deeper are an error,
// as for ScanQueryFolder.
absl::StatusOr<std::vector<EnrollImage>> ScanUnheadedFolder(const std::filesystem::path& dir);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_ENROLL_MANIFEST_H_
