#include "client/common/numeric_table.h"

#include <cmath>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"

namespace waymark::cli {

absl::StatusOr<std::vector<NumericRow>> ParseNumericRows(const std::string& text, int columns,
                                                         absl::string_view layout,
                                                         absl::string_view separators) {
  std::vector<NumericRow> rows;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line[0] == '#') continue;
    std::vector<absl::string_view> fields =
        absl::StrSplit(line, absl::ByAnyChar(separators), absl::SkipEmpty());
    if (static_cast<int>(fields.size()) != columns) {
      return absl::InvalidArgumentError(absl::StrCat("line ", line_number, ": expected ", columns,
                                                     " fields (", layout, "), got ",
                                                     fields.size()));
    }
    NumericRow row;
    row.line = line_number;
    row.values.resize(columns);
    for (int i = 0; i < columns; ++i) {
      if (!absl::SimpleAtod(fields[i], &row.values[i]) || !std::isfinite(row.values[i])) {
        return absl::InvalidArgumentError(absl::StrCat("line ", line_number, ": field ", i + 1,
                                                       " is not a finite number: '", fields[i],
                                                       "'"));
      }
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace waymark::cli
