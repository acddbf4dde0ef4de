#ifndef WAYMARK_CLIENT_COMMON_OUTPUT_H_
#define WAYMARK_CLIENT_COMMON_OUTPUT_H_

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "client/common/command_context.h"

namespace waymark::cli {

// Prints "error: CODE_NAME: message" on context.err and returns kExitFailure. `what` (optional)
// says which input the error belongs to, e.g. a file name. A call that found no server
// (client::IsUnavailableCall) adds "is the server running at ADDRESS?" with the address dialled.
int ReportError(const CommandContext& context, const absl::Status& status,
                std::string_view what = {});

// One JSON document, pretty-printed, newline-terminated.
void PrintJson(std::ostream& out, const nlohmann::json& document);

// nullopt -> null, so "not applicable" stays distinguishable from 0 in --json output.
nlohmann::json OptionalJson(const std::optional<double>& value);

// "12.3" with `decimals` decimals, or "-" for nullopt.
std::string FormatNumber(const std::optional<double>& value, int decimals = 1);
// "93.5%" for a fraction in [0, 1], or "-" for nullopt.
std::string FormatPercent(const std::optional<double>& fraction);

// "512 B", "15.8 KiB", "3.2 MiB", "1.1 GiB".
std::string FormatBytes(int64_t bytes);

// A plain text table with aligned columns; numeric columns are right-aligned.
class Table {
 public:
  struct Column {
    std::string header;
    bool numeric = false;
  };
  explicit Table(std::vector<Column> columns) : columns_(std::move(columns)) {}

  // Missing cells print empty; extra cells are an error in the caller and are dropped.
  void AddRow(std::vector<std::string> cells);
  bool empty() const { return rows_.empty(); }
  void Print(std::ostream& out) const;

 private:
  std::vector<Column> columns_;
  std::vector<std::vector<std::string>> rows_;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_OUTPUT_H_
