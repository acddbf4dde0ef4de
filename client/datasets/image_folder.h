#ifndef WAYMARK_CLIENT_DATASETS_IMAGE_FOLDER_H_
#define WAYMARK_CLIENT_DATASETS_IMAGE_FOLDER_H_

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::cli {

// Folder layouts the `enroll`, `eval` and `recognize` commands read. Pure file-system scanning, no
// server. Hidden entries (names starting with '.') and files that are not images are ignored.
//
// Enrollment: DIR/<crossing>/<heading>.<ext>, one folder per crossing, one image per heading; or,
// for a crossing captured from several places, DIR/<crossing>/<position>/<heading>.<ext>, one
// folder per capture position (its name is the position tag, e.g. "north-kerb" or "p2"), one image
// per heading in each. The layout is decided per crossing folder: one holding images is the first
// layout, one holding folders of images the second, one holding both is an error. So one DIR may
// mix crossings captured from one place with crossings captured from several.
// A heading file name (the stem, before the extension) is the compass heading in degrees,
// clockwise, written as
//   1 to 3 digits, optionally followed by '.' and 1 or more digits, and nothing else
// (no sign, exponent, spaces or units), with a value in [0, 360). So 0.jpg, 030.jpg, 30.5.png and
// 359.9.jpeg are headings; 360.jpg and 400.jpg are outside [0, 360) (never wrapped: 400 is a typo
// or a frame number, not 40 degrees); 0000110.jpg (a numbered video frame), -30.jpg, 1e2.jpg and
// left.jpg are not headings.

// Query folder that holds places which are not in the database and must be rejected.
inline constexpr char kUnknownFolder[] = "unknown";

// The layout `enroll` expects, for messages.
inline constexpr char kEnrollLayout[] =
    "DIR/<crossing>/<heading_deg>.jpg (or .jpeg, .png), one folder per crossing, or "
    "DIR/<crossing>/<position>/<heading_deg>.jpg for a crossing captured from several positions; "
    "the heading in degrees in [0, 360) with at most 3 integer digits, e.g. "
    "DIR/main-and-1st/030.jpg or DIR/main-and-1st/north-kerb/30.5.png";

// One view to enroll: DIR/<crossing>/<heading_deg>.<ext>, DIR/<crossing>/<position>/<heading>.<ext>
// or a frame of a video (client/datasets/video_frames.h).
struct EnrollImage {
  std::string crossing;
  double heading_deg = 0;
  std::filesystem::path path;  // the image file, or the video a frame came from
  std::string position;        // capture position; empty = not tagged
  std::string encoded;         // the encoded image when it is no file of its own (a video frame)
};

// One query for evaluation: DIR/<folder>/<anything>.<ext>.
struct QueryImage {
  std::string folder;  // the true crossing, or kUnknownFolder
  std::filesystem::path path;
  std::optional<double> heading_deg;  // when the file stem is a heading (ParseHeading)

  bool unknown() const { return folder == kUnknownFolder; }
};

// .jpg, .jpeg or .png, in any letter case.
bool IsImageFile(const std::filesystem::path& path);

// The heading the file's stem names, by the rule above ("030.jpg" -> 30, "30.5.png" -> 30.5).
// INVALID_ARGUMENT naming the file and saying what is wrong (not a heading, too many digits,
// outside [0, 360)).
absl::StatusOr<double> ParseHeading(const std::filesystem::path& file);

// All views under `dir`, sorted by crossing name, then position, then heading, so repeated imports
// enroll (and therefore cluster) in the same order. The whole layout is checked first and every
// problem is reported at once, with the expected layout: images directly in `dir` or deeper than
// `dir/<crossing>/<position>/` (e.g. "found images in DIR/a/b/c/: one level too deep?"), a crossing
// folder holding both images and position folders, file names that are not headings, two files of
// one crossing (and position) with the same heading. NOT_FOUND when `dir` is not a directory;
// INVALID_ARGUMENT for a bad or empty layout.
absl::StatusOr<std::vector<EnrollImage>> ScanEnrollFolder(const std::filesystem::path& dir);

// All queries under `dir` (DIR/<folder>/<file>), sorted by folder, then file name. Stems need not
// be headings. Images directly in `dir` or deeper than one folder are an error, as for enrollment.
absl::StatusOr<std::vector<QueryImage>> ScanQueryFolder(const std::filesystem::path& dir);

// The images directly in `dir`, sorted by file name (`recognize NAME DIR`). INVALID_ARGUMENT when
// there are none, saying where images were found instead (e.g. in crossing folders, for which
// `waymark eval` is the command).
absl::StatusOr<std::vector<std::filesystem::path>> ListFolderImages(const std::filesystem::path& dir);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_IMAGE_FOLDER_H_
