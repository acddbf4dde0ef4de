#ifndef WAYMARK_CLIENT_COMMON_NUMERIC_TABLE_H_
#define WAYMARK_CLIENT_COMMON_NUMERIC_TABLE_H_

// Text tables of numbers, one record per line (relations files, TUM trajectories): blank lines and
// '#' comments skipped, every field a finite number, errors naming the line.

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "client/common/read_file.h"

namespace waymark::cli {

struct NumericRow {
  int line = 0;  // 1-based
  std::vector<double> values;
};

// `layout` names the columns for error messages ("t x y z qx qy qz qw"); `separators` are the
// characters between fields.
absl::StatusOr<std::vector<NumericRow>> ParseNumericRows(const std::string& text, int columns,
                                                         absl::string_view layout,
                                                         absl::string_view separators);

// Reads the file and parses it with `parse`; a parse error is prefixed with the path.
template <typename Parse>
auto ReadAndParse(const std::filesystem::path& path, Parse parse)
    -> decltype(parse(std::string())) {
  absl::StatusOr<std::string> text = ReadFileBytes(path);
  if (!text.ok()) return text.status();
  auto parsed = parse(*text);
  if (!parsed.ok()) {
    return absl::Status(parsed.status().code(),
                        absl::StrCat(path.string(), ": ", parsed.status().message()));
  }
  return parsed;
}

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_NUMERIC_TABLE_H_
