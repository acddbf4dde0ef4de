#include "client/datasets/enroll_manifest.h"

#include <charconv>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace waymark::cli {
namespace fs = std::filesystem;
namespace {

// At most this many problems are listed; the count of the rest follows.
constexpr size_t kMaxProblems = 20;

// One CSV line into fields: commas separate, a field starting with '"' runs to the next lone
// '"' ("" is a quote inside). nullopt for an unterminated quote.
std::optional<std::vector<std::string>> SplitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  size_t i = 0;
  bool quoted_field = false;
  while (true) {
    if (i < line.size() && line[i] == '"' && field.empty() && !quoted_field) {
      quoted_field = true;
      ++i;
      bool closed = false;
      while (i < line.size()) {
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            field += '"';
            i += 2;
            continue;
          }
          ++i;
          closed = true;
          break;
        }
        field += line[i++];
      }
      if (!closed) return std::nullopt;
      continue;
    }
    if (i >= line.size() || line[i] == ',') {
      fields.push_back(quoted_field ? field : std::string(absl::StripAsciiWhitespace(field)));
      field.clear();
      quoted_field = false;
      if (i >= line.size()) break;
      ++i;
      continue;
    }
    field += line[i++];
  }
  return fields;
}

// A heading field: digits ['.' digits] in [0, 360), or empty / "unknown" / "-" for none (NaN).
absl::StatusOr<double> ParseHeadingField(const std::string& field) {
  const std::string lower = absl::AsciiStrToLower(field);
  if (lower.empty() || lower == "unknown" || lower == "-") return kUnknownHeading;
  size_t end = 0;
  while (end < field.size() && absl::ascii_isdigit(field[end])) ++end;
  bool number = end > 0;
  if (end < field.size() && field[end] == '.') {
    const size_t fraction = ++end;
    while (end < field.size() && absl::ascii_isdigit(field[end])) ++end;
    number = number && end > fraction;
  }
  if (!number || end != field.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "heading '", field, "' is not a number of degrees (give e.g. 30 or 292.5, or leave it "
        "empty or write unknown when the view's heading is not known)"));
  }
  double value = 0;
  std::from_chars(field.data(), field.data() + field.size(), value);
  if (!(value < 360)) {
    return absl::InvalidArgumentError(
        absl::StrCat("heading ", field, " is outside [0, 360) (headings are not wrapped)"));
  }
  return value;
}

}  // namespace

absl::StatusOr<std::vector<EnrollImage>> ParseEnrollManifest(const std::string& text,
                                                             const fs::path& base) {
  std::vector<EnrollImage> images;
  std::vector<std::string> problems;
  std::map<std::string, int> file_lines;  // resolved path -> first line
  // (crossing, position, heading) of views with a known heading -> first line.
  std::map<std::tuple<std::string, std::string, double>, int> place_lines;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  bool first = true;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (number == 1 && absl::StartsWith(line, "\xEF\xBB\xBF")) line.erase(0, 3);  // a BOM
    const std::string trimmed(absl::StripAsciiWhitespace(line));
    if (trimmed.empty() || trimmed[0] == '#') continue;
    std::optional<std::vector<std::string>> fields = SplitCsvLine(line);
    const bool header = first && fields.has_value() && !fields->empty() &&
                        absl::AsciiStrToLower((*fields)[0]) == "file";
    first = false;
    if (header) continue;
    const auto problem = [&](const std::string& what) {
      problems.push_back(absl::StrCat("line ", number, ": ", what));
    };
    if (!fields.has_value()) {
      problem("a quoted field is not closed");
      continue;
    }
    if (fields->size() < 3 || fields->size() > 4) {
      problem(absl::StrCat(fields->size(), " fields, expected file,crossing,heading[,position]"));
      continue;
    }
    EnrollImage image;
    const std::string& file = (*fields)[0];
    image.crossing = (*fields)[1];
    if (fields->size() == 4) image.position = (*fields)[3];
    bool ok = true;
    if (file.empty()) {
      problem("no file");
      ok = false;
    } else {
      image.path = fs::path(file).is_absolute() ? fs::path(file) : base / file;
      std::error_code error;
      if (!IsImageFile(image.path)) {
        problem(absl::StrCat("'", file, "' is not an image (.jpg, .jpeg or .png)"));
        ok = false;
      } else if (!fs::is_regular_file(image.path, error)) {
        problem(absl::StrCat("'", image.path.string(), "' does not exist or is not a file"));
        ok = false;
      } else {
        const std::string key = fs::weakly_canonical(image.path, error).string();
        auto [it, inserted] = file_lines.emplace(key, number);
        if (!inserted) {
          problem(absl::StrCat("'", file, "' is listed again (first on line ", it->second, ")"));
          ok = false;
        }
      }
    }
    if (image.crossing.empty()) {
      problem("no crossing");
      ok = false;
    }
    absl::StatusOr<double> heading = ParseHeadingField((*fields)[2]);
    if (!heading.ok()) {
      problem(std::string(heading.status().message()));
      ok = false;
    } else {
      image.heading_deg = *heading;
    }
    if (ok && HasHeading(image)) {
      auto [it, inserted] = place_lines.emplace(
          std::make_tuple(image.crossing, image.position, image.heading_deg), number);
      if (!inserted) {
        problem(absl::StrCat("crossing ", image.crossing,
                             image.position.empty() ? "" : absl::StrCat(" position ", image.position),
                             " has heading ", (*fields)[2], " already on line ", it->second,
                             " (one view per heading and position; leave the heading empty when "
                             "it is not known)"));
        ok = false;
      }
    }
    if (ok) images.push_back(std::move(image));
  }
  if (!problems.empty()) {
    const size_t total = problems.size();
    if (total > kMaxProblems) {
      problems.resize(kMaxProblems);
      problems.push_back(absl::StrCat("... and ", total - kMaxProblems, " more"));
    }
    return absl::InvalidArgumentError(absl::StrCat("the manifest has ", total, " problem",
                                                   total == 1 ? "" : "s", " (expected ",
                                                   kManifestLayout, "):\n  ",
                                                   absl::StrJoin(problems, "\n  ")));
  }
  if (images.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("the manifest lists no view; expected ", kManifestLayout));
  }
  return images;
}

absl::StatusOr<std::vector<EnrollImage>> ReadEnrollManifest(const fs::path& manifest) {
  std::ifstream in(manifest, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(absl::StrCat("cannot read the manifest '", manifest.string(), "'"));
  }
  std::stringstream text;
  text << in.rdbuf();
  absl::StatusOr<std::vector<EnrollImage>> images =
      ParseEnrollManifest(text.str(), manifest.parent_path());
  if (!images.ok()) {
    return absl::Status(images.status().code(),
                        absl::StrCat(manifest.string(), ": ", images.status().message()));
  }
  return images;
}

absl::StatusOr<std::vector<EnrollImage>> ScanUnheadedFolder(const fs::path& dir) {
  absl::StatusOr<std::vector<QueryImage>> files = ScanQueryFolder(dir);
  if (!files.ok()) return files.status();
  std::vector<EnrollImage> images;
  for (const QueryImage& file : *files) {
    EnrollImage image;
    image.crossing = file.folder;
    image.heading_deg = kUnknownHeading;
    image.path = file.path;
    images.push_back(std::move(image));
  }
  return images;
}

}  // namespace waymark::cli
