#include "client/common/output.h"

#include <fmt/format.h>

#include <algorithm>

#include "absl/status/status.h"
#include "client/lib/status_util.h"

namespace waymark::cli {

int ReportError(const CommandContext& context, const absl::Status& status, std::string_view what) {
  context.err << "error: " << absl::StatusCodeToString(status.code()) << ": " << status.message();
  if (!what.empty()) context.err << " (" << what << ")";
  // gRPC's transport errors ("failed to connect to all addresses", "Socket closed") name no
  // address, or not the one the user typed (or took from WAYMARK_SERVER): name the one dialled.
  if (client::IsUnavailableCall(status)) {
    context.err << ": is the server running at " << context.globals.server
                << "? (--server HOST[:PORT] or WAYMARK_SERVER names another)";
  } else if (status.code() == absl::StatusCode::kDeadlineExceeded) {
    context.err << " [server " << context.globals.server << "]";
  }
  context.err << "\n";
  return kExitFailure;
}

void PrintJson(std::ostream& out, const nlohmann::json& document) {
  out << document.dump(2) << "\n";
}

nlohmann::json OptionalJson(const std::optional<double>& value) {
  return value.has_value() ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

std::string FormatNumber(const std::optional<double>& value, int decimals) {
  return value.has_value() ? fmt::format("{:.{}f}", *value, decimals) : "-";
}

std::string FormatPercent(const std::optional<double>& fraction) {
  return fraction.has_value() ? fmt::format("{:.1f}%", 100.0 * *fraction) : "-";
}

std::string FormatBytes(int64_t bytes) {
  if (bytes < 1024) return fmt::format("{} B", bytes);
  double value = static_cast<double>(bytes);
  for (const char* unit : {"KiB", "MiB", "GiB"}) {
    value /= 1024;
    if (value < 1024 || unit[0] == 'G') return fmt::format("{:.1f} {}", value, unit);
  }
  return {};  // not reached
}

void Table::AddRow(std::vector<std::string> cells) {
  cells.resize(columns_.size());
  rows_.push_back(std::move(cells));
}

void Table::Print(std::ostream& out) const {
  std::vector<size_t> widths;
  for (const Column& column : columns_) widths.push_back(column.header.size());
  for (const auto& row : rows_) {
    for (size_t i = 0; i < row.size(); ++i) widths[i] = std::max(widths[i], row[i].size());
  }
  auto print_row = [&](auto cell_at) {
    std::string line;
    for (size_t i = 0; i < columns_.size(); ++i) {
      if (i > 0) line += "  ";
      line += columns_[i].numeric ? fmt::format("{:>{}}", cell_at(i), widths[i])
                                  : fmt::format("{:<{}}", cell_at(i), widths[i]);
    }
    line.erase(line.find_last_not_of(' ') + 1);
    out << line << "\n";
  };
  print_row([&](size_t i) { return columns_[i].header; });
  for (const auto& row : rows_) print_row([&](size_t i) { return row[i]; });
}

}  // namespace waymark::cli
