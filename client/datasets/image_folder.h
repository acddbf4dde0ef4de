#ifndef WAYMARK_CLIENT_DATASETS_IMAGE_FOLDER_H_
#define WAYMARK_CLIENT_DATASETS_IMAGE_FOLDER_H_

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::cli {

// Folder layouts the `enroll` and `eval` commands read. Pure file-system scanning, no server.

// Query folder that holds places which are not in the database and must be rejected.
inline constexpr char kUnknownFolder[] = "unknown";

// One view to enroll: DIR/<crossing>/<heading_deg>.<ext>.
struct EnrollImage {
  std::string crossing;
  double heading_deg = 0;
  std::filesystem::path path;
};

// One query for evaluation: DIR/<folder>/<anything>.<ext>.
struct QueryImage {
  std::string folder;  // the true crossing, or kUnknownFolder
  std::filesystem::path path;
  std::optional<double> heading_deg;  // when the file stem is a number

  bool unknown() const { return folder == kUnknownFolder; }
};

// .jpg, .jpeg or .png, in any letter case.
bool IsImageFile(const std::filesystem::path& path);

// The heading in the file's stem ("030.jpg" -> 30, "30.5.png" -> 30.5), normalised to [0, 360).
// INVALID_ARGUMENT naming the file when the stem is not a finite decimal number.
absl::StatusOr<double> ParseHeading(const std::filesystem::path& file);

// All views under `dir`, sorted by crossing name, then heading, then path, so repeated imports
// enroll (and therefore cluster) in the same order. Non-image files and hidden entries are skipped;
// an image directly in `dir` or with a non-numeric stem is an error naming the file.
absl::StatusOr<std::vector<EnrollImage>> ScanEnrollFolder(const std::filesystem::path& dir);

// All queries under `dir`, sorted by folder, then file name. Same skipping rules; stems need not be
// numbers.
absl::StatusOr<std::vector<QueryImage>> ScanQueryFolder(const std::filesystem::path& dir);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_IMAGE_FOLDER_H_
