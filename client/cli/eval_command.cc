// `waymark eval NAME QUERY_DIR`: runs every query of QUERY_DIR/<crossing>/<file> and reports the
// evaluation protocol's metrics (eval_metrics.h).
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
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
#include "client/cli/recognition_output.h"

namespace waymark::cli {
namespace {

struct EvalArgs {
  std::string database;
  std::string query_dir;
  std::string per_query_csv;
  RecognitionFlags recognition;
};

// What eval needs of an answer beyond the metrics: why it was accepted (the per-query CSV's
// extra columns) and whether the mode ran with the stages it relies on.
struct AnswerNotes {
  std::string csv;            // RecognitionCsvFields
  bool retrieval = false;     // the server applied the retrieval mode
  bool global_stage = false;  // ... with its global stage
  std::string skipped;        // ... or why not (RecognizeResponse.global_stage_skipped)
};

// Why queries ran without the global stage, by the answer's reason
// (RecognizeResponse.global_stage_skipped): the query's own lack is not the database's.
std::string WithoutGlobalCause(const std::string& skipped) {
  static const std::map<std::string, std::string> kCauses = {
      {"no_keypoints",
       "the query had no SIFT keypoints (an image without texture), so no stage could accept it"},
      {"no_vocabulary",
       "the database had no vocabulary yet (it learns its first at 16 views), so only the "
       "geometric NFA could accept"},
      {"off",
       "the database keeps no global stage (created in another mode or with "
       "--no-global-descriptor), so only the geometric NFA could accept"},
      {"no_dense",
       "the query carried no dense descriptors (the vocabulary was learnt while it was "
       "extracted)"},
      {"not_coded", "the database's views were not coded yet (see `db stats`)"},
  };
  const auto it = kCauses.find(skipped);
  // A server older than the reason: the causes it could have had.
  return it != kCauses.end() ? it->second
                             : "the server gave no reason (the database has no vocabulary or "
                               "keeps no global stage, or the query had no keypoints)";
}

// Runs one query. Errors stop the evaluation: metrics over a partial set would mislead.
absl::StatusOr<QueryRecord> RunQuery(client::CrossingClient& client, const EvalArgs& args,
                                     const QueryImage& query, AnswerNotes* notes) {
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
  notes->csv = RecognitionCsvFields(*response);
  notes->retrieval = response->mode() == v1::RECOGNITION_MODE_RETRIEVAL;
  notes->global_stage = response->global_stage();
  notes->skipped = response->global_stage_skipped();
  return record;
}

// The per-query CSV of eval_report.h with the answer's path and numbers appended to each row
// (RecognitionCsvFields). Rows end at a line break outside quotes.
std::string AppendColumns(const std::string& csv, const std::vector<std::string>& extra) {
  std::string out;
  size_t row = 0;
  bool quoted = false;
  for (char c : csv) {
    if (c == '"') quoted = !quoted;
    if (c == '\n' && !quoted) {
      out += ',';
      out += row == 0 ? RecognitionCsvHeader() : (row - 1 < extra.size() ? extra[row - 1] : ",,,");
      ++row;
    }
    out += c;
  }
  return out;
}

absl::Status WriteCsv(const std::string& path, const std::vector<QueryRecord>& records,
                      const std::vector<std::string>& extra) {
  std::ofstream out(path);
  if (!out) return absl::PermissionDeniedError("cannot write '" + path + "'");
  std::ostringstream base;
  WritePerQueryCsv(base, records);
  out << AppendColumns(base.str(), extra);
  out.close();
  if (!out) return absl::DataLossError("writing '" + path + "' failed");
  return absl::OkStatus();
}

int RunEval(CommandContext& context, const EvalArgs& args) {
  auto queries = ScanQueryFolder(args.query_dir);
  if (!queries.ok()) return ReportError(context, queries.status());

  std::unique_ptr<client::CrossingClient> client = context.Connect();
  // The crossings the database holds: a query folder naming none of them is a place that was
  // never stored (e.g. every view refused at enrollment), counted apart, neither known nor
  // "unknown".
  v1::ListCrossingsRequest list_request;
  list_request.set_database(args.database);
  auto crossings = client->ListCrossings(list_request);
  std::set<std::string> stored;
  if (crossings.ok()) {
    for (const v1::Crossing& c : crossings->crossings()) {
      if (c.views() > 0) stored.insert(c.name());
    }
  } else {
    context.err << "warning: cannot list the database's crossings (" << crossings.status().message()
                << "): every query folder is taken for a stored crossing\n";
  }
  ProgressBar progress(context.err, static_cast<int>(queries->size()), "queries",
                       context.err_is_tty);
  std::vector<QueryRecord> records;
  std::vector<std::string> extra;
  std::vector<QueryOutcome> outcomes;
  std::set<std::string> never_stored;
  int never_stored_queries = 0, never_stored_accepted = 0;
  int retrieval_queries = 0, without_global = 0;
  std::map<std::string, int> without_global_by_cause;  // global_stage_skipped -> queries
  for (const QueryImage& query : *queries) {
    AnswerNotes notes;
    auto record = RunQuery(*client, args, query, &notes);
    if (!record.ok()) {
      progress.Finish();
      return ReportError(context, record.status(),
                         fmt::format("query {} after {} of {}", query.path.string(), records.size(),
                                     queries->size()));
    }
    if (notes.retrieval) {
      ++retrieval_queries;
      if (!notes.global_stage) {
        ++without_global;
        ++without_global_by_cause[notes.skipped.empty() ? "unknown" : notes.skipped];
      }
    }
    if (crossings.ok() && !query.unknown() && stored.count(query.folder) == 0) {
      never_stored.insert(query.folder);
      ++never_stored_queries;
      if (record->outcome.recognized) ++never_stored_accepted;
    } else {
      outcomes.push_back(record->outcome);
    }
    extra.push_back(notes.csv);
    records.push_back(*std::move(record));
    progress.Update(static_cast<int>(records.size()));
  }
  progress.Finish();

  if (without_global > 0) {
    std::string causes;
    for (const auto& [skipped, count] : without_global_by_cause) {
      causes += fmt::format("{}{} because {}", causes.empty() ? "" : "; ", count,
                            WithoutGlobalCause(skipped));
    }
    context.err << fmt::format(
        "warning: {} of {} retrieval-mode queries ran without the global stage: {}\n",
        without_global, retrieval_queries, causes);
  }
  if (never_stored_queries > 0) {
    std::string names;
    for (const std::string& n : never_stored) names += (names.empty() ? "" : ", ") + n;
    context.err << fmt::format(
        "note: {} queries of {} crossing(s) the database never stored ({}) are counted apart, "
        "not as known places: {} of them accepted (as another crossing)\n",
        never_stored_queries, never_stored.size(), names, never_stored_accepted);
  }
  if (!args.per_query_csv.empty()) {
    if (absl::Status status = WriteCsv(args.per_query_csv, records, extra); !status.ok()) {
      return ReportError(context, status);
    }
  }
  const EvalSummary summary = Summarize(outcomes);
  if (context.globals.json) {
    nlohmann::json json = SummaryToJson(summary);
    json["database"] = args.database;
    json["never_stored"] = {{"queries", never_stored_queries},
                            {"crossings", std::vector<std::string>(never_stored.begin(),
                                                                   never_stored.end())},
                            {"accepted", never_stored_accepted}};
    json["without_global_stage"] = {{"queries", without_global},
                                    {"retrieval_queries", retrieval_queries},
                                    {"causes", without_global_by_cause}};
    PrintJson(context.out, json);
  } else {
    PrintSummary(context.out, summary);
    if (never_stored_queries > 0) {
      context.out << fmt::format(
          "never stored: {} queries of {} crossing(s), counted apart ({} accepted)\n",
          never_stored_queries, never_stored.size(), never_stored_accepted);
    }
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
