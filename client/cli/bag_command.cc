// `waymark bag info BAG`: what a ROS 1 bag, rosbag2 bag or MCAP file holds, like `rosbag info`:
// format, files, duration, start and end, compression, messages, and per topic its type and
// count. Reads the file's index or summary when it has one; needs no server.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "absl/time/time.h"
#include "client/bags/bag_reader.h"
#include "client/cli/command.h"
#include "client/common/output.h"

namespace waymark::cli {
namespace {

// Seconds with milliseconds, truncated like the UTC time beside it.
std::string BagSeconds(int64_t ns) {
  char text[40];
  std::snprintf(text, sizeof(text), "%lld.%03lld", static_cast<long long>(ns / 1000000000),
                static_cast<long long>((ns % 1000000000) / 1000000));
  return text;
}

// "1518520197.647 (2018-02-13 11:09:57.647 UTC)"; stamps before 1980 are simulated clocks,
// printed as seconds alone.
std::string BagStamp(int64_t ns) {
  std::string out = BagSeconds(ns);
  if (ns > int64_t{315532800} * 1000000000) {
    out += " (" + absl::FormatTime("%Y-%m-%d %H:%M:%E3S UTC", absl::FromUnixNanos(ns), absl::UTCTimeZone()) + ")";
  }
  return out;
}

int RunBagInfo(CommandContext& context, const std::string& path) {
  absl::StatusOr<std::unique_ptr<bags::BagReader>> bag = bags::OpenBag(path);
  if (!bag.ok()) return ReportError(context, bag.status());  // the message names the path
  absl::StatusOr<bags::BagSummary> summary = (*bag)->Summary();
  if (!summary.ok()) return ReportError(context, summary.status(), path);
  const std::vector<std::string>& warnings = (*bag)->warnings();
  const int64_t duration = summary->messages > 0 ? summary->end_ns - summary->start_ns : 0;
  if (context.globals.json) {
    nlohmann::json topics = nlohmann::json::array();
    for (const bags::BagTopicSummary& topic : summary->topics) {
      topics.push_back({{"topic", topic.topic}, {"type", topic.type}, {"messages", topic.messages}});
    }
    PrintJson(context.out, {{"path", path},
                            {"format", summary->format},
                            {"files", summary->files},
                            {"compression", summary->compression},
                            {"messages", summary->messages},
                            {"start_ns", summary->messages > 0 ? nlohmann::json(summary->start_ns) : nlohmann::json()},
                            {"end_ns", summary->messages > 0 ? nlohmann::json(summary->end_ns) : nlohmann::json()},
                            {"duration_s", static_cast<double>(duration) / 1e9},
                            {"topics", topics},
                            {"warnings", warnings}});
    return kExitOk;
  }
  std::ostream& out = context.out;
  out << "path:        " << path << "\n";
  out << "format:      " << summary->format << "\n";
  if (summary->files.size() > 1 || (summary->files.size() == 1 && summary->files[0] != path)) {
    out << "files:       " << summary->files.size() << "\n";
    for (const std::string& file : summary->files) out << "             " << file << "\n";
  }
  out << "duration:    " << BagSeconds(duration) << " s\n";
  if (summary->messages > 0) {
    out << "start:       " << BagStamp(summary->start_ns) << "\n";
    out << "end:         " << BagStamp(summary->end_ns) << "\n";
  }
  out << "messages:    " << summary->messages << "\n";
  out << "compression: " << summary->compression << "\n";
  Table table({{"topic"}, {"type"}, {"messages", true}});
  for (const bags::BagTopicSummary& topic : summary->topics) {
    table.AddRow({topic.topic, topic.type, std::to_string(topic.messages)});
  }
  if (!table.empty()) {
    out << "\n";
    table.Print(out);
  }
  for (const std::string& warning : warnings) context.err << "warning: " << warning << "\n";
  return kExitOk;
}

}  // namespace

void AddBagCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* bag = app.add_subcommand("bag", "Recorded robot data: ROS 1 bags, rosbag2 bags, MCAP files");
  bag->require_subcommand(1);
  auto path = std::make_shared<std::string>();
  CLI::App* info = bag->add_subcommand(
      "info", "Format, duration, compression and each topic's type and message count (no server needed)");
  info->add_option("BAG", *path, "A .bag or .mcap file, a rosbag2 folder (or its metadata.yaml or .db3)")
      ->required();
  registry.Add(info, [path](CommandContext& context) { return RunBagInfo(context, *path); });
}

}  // namespace waymark::cli
