// `waymark eval NAME QUERY_DIR`: runs every query of QUERY_DIR/<crossing>/<file> and reports the
// evaluation protocol's metrics (eval_metrics.h).
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/cli/command.h"
#include "client/eval/eval_metrics.h"
#include "client/eval/eval_report.h"
#include "client/datasets/image_folder.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/common/read_file.h"
#include "client/cli/recognition_flags.h"

namespace waymark::cli {
namespace {

struct EvalArgs {
  std::string database;
  std::string query_dir;
  std::string per_query_csv;
  RecognitionFlags recognition;
};

// Runs one query. Errors stop the evaluation: metrics over a partial set would mislead.
absl::StatusOr<QueryRecord> RunQuery(client::CrossingClient& client, const EvalArgs& args,
                                     const QueryImage& query) {
  auto bytes = ReadFileBytes(query.path);
  if (!bytes.ok()) return bytes.status();
  v1::RecognizeRequest request;
  request.set_database(args.database);
  request.mutable_image()->set_data(*std::move(bytes));
  *request.mutable_params() = args.recognition.ToParams();

  const auto start = std::chrono::steady_clock::now();
  auto response = client.RecognizeCrossing(request);
  const double latency_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!response.ok()) return response.status();

  QueryRecord record;
  record.path = query.path.string();
  record.outcome.truth = query.folder;
  record.outcome.true_heading_deg = query.heading_deg;
  record.outcome.recognized = response->recognized();
  record.outcome.predicted = response->crossing();
  record.outcome.predicted_heading_deg = response->heading_deg();
  record.outcome.latency_ms = latency_ms;
  record.decision = response->decision();
  record.keypoints = response->keypoints();
  record.server_ms = response->timings().total_ms();
  record.reason = response->reason();
  return record;
}

absl::Status WriteCsv(const std::string& path, const std::vector<QueryRecord>& records) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError("cannot write '" + path + "'");
  WritePerQueryCsv(out, records);
  out.close();
  if (!out) return absl::DataLossError("writing '" + path + "' failed");
  return absl::OkStatus();
}

int RunEval(CommandContext& context, const EvalArgs& args) {
  auto queries = ScanQueryFolder(args.query_dir);
  if (!queries.ok()) return ReportError(context, queries.status());

  std::unique_ptr<client::CrossingClient> client = context.Connect();
  ProgressBar progress(context.err, static_cast<int>(queries->size()), "queries",
                       context.err_is_tty);
  std::vector<QueryRecord> records;
  std::vector<QueryOutcome> outcomes;
  for (const QueryImage& query : *queries) {
    auto record = RunQuery(*client, args, query);
    if (!record.ok()) {
      progress.Finish();
      return ReportError(context, record.status(),
                         fmt::format("query {} after {} of {}", query.path.string(), records.size(),
                                     queries->size()));
    }
    outcomes.push_back(record->outcome);
    records.push_back(*std::move(record));
    progress.Update(static_cast<int>(records.size()));
  }
  progress.Finish();

  if (!args.per_query_csv.empty()) {
    if (absl::Status status = WriteCsv(args.per_query_csv, records); !status.ok()) {
      return ReportError(context, status);
    }
  }
  const EvalSummary summary = Summarize(outcomes);
  if (context.globals.json) {
    nlohmann::json json = SummaryToJson(summary);
    json["database"] = args.database;
    PrintJson(context.out, json);
  } else {
    PrintSummary(context.out, summary);
  }
  return kExitOk;
}

}  // namespace

void AddEvalCommand(CLI::App& app, CommandRegistry& registry) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* eval = app.add_subcommand(
      "eval",
      "Evaluate recognition on QUERY_DIR/<crossing>/<file>.(jpg|png); a folder named 'unknown' "
      "holds places not in the database, which must be rejected");
  // Required at run time rather than by CLI11, so `eval relations ...` needs neither.
  eval->add_option("NAME", args->database, "Database name");
  eval->add_option("QUERY_DIR", args->query_dir, "Folder of query folders");
  eval->add_option("--per-query", args->per_query_csv, "Write one CSV row per query to FILE.csv");
  args->recognition.Register(eval);
  registry.Add(eval, [args](CommandContext& c) {
    if (args->database.empty() || args->query_dir.empty()) {
      return ReportError(c, absl::InvalidArgumentError(
                                "eval needs NAME and QUERY_DIR (or a subcommand: eval relations)"));
    }
    return RunEval(c, *args);
  });
}

}  // namespace waymark::cli
