#include "client/cli/recognition_output.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "client/common/output.h"
#include "client/common/proto_json.h"

namespace waymark::cli {

namespace {

// A view enrolled with no heading (a manifest row with an empty heading) answers NaN.
std::string HeadingText(double heading_deg) {
  return std::isnan(heading_deg) ? std::string("no heading")
                                 : fmt::format("heading {:.1f} deg", heading_deg);
}

// The global path's numbers: "similarity 0.412 (crossing B), 10^-3.1 false alarms by chance".
std::string GlobalNumbers(const v1::RecognizeResponse& r, bool name_crossing) {
  if (!r.global_stage()) return "";
  std::string out = fmt::format("global similarity {:.3f}", r.global_similarity());
  if (name_crossing && !r.global_crossing().empty()) {
    out += fmt::format(" ({})", r.global_crossing());
  }
  out += r.global_model()
             ? fmt::format(", 10^{:.1f} false alarms by chance", r.global_log10_false_alarms())
             : ", no chance model (too few views of other crossings)";
  return out;
}

std::string NfaNumbers(const v1::RecognizeResponse& r) {
  return r.nfa_computed() ? fmt::format("NFA 10^{:.1f}", r.log10_nfa())
                          : "NFA not computed (no geometric match set)";
}

}  // namespace

std::string RecognitionWhy(const v1::RecognizeResponse& r) {
  const std::string path = r.accepted_by().empty() ? (r.recognized() ? "" : "refused")
                                                   : r.accepted_by();
  if (r.mode() != v1::RECOGNITION_MODE_RETRIEVAL) {
    return path.empty() ? "" : fmt::format("accepted by {}", path);
  }
  std::string numbers;
  if (path == "global" || path == "global_lift") {
    numbers = GlobalNumbers(r, false) + "; " + NfaNumbers(r);
    if (path == "global_lift") numbers += fmt::format("; lift {:.3f}", r.global_lift());
  } else {
    numbers = NfaNumbers(r);
    const std::string global = GlobalNumbers(r, true);
    if (!global.empty()) numbers += "; " + global;
  }
  if (!r.global_stage()) {
    numbers += "; ran without a global stage";
    if (!r.global_stage_skipped().empty()) numbers += " (" + r.global_stage_skipped() + ")";
  }
  return path == "refused" ? fmt::format("refused: {}", numbers)
                           : fmt::format("accepted by {}: {}", path.empty() ? "?" : path, numbers);
}

std::string RecognitionCsvHeader() {
  return "accepted_by,log10_nfa,global_similarity,global_log10_false_alarms";
}

std::string RecognitionCsvFields(const v1::RecognizeResponse& r) {
  const std::string path =
      r.accepted_by().empty() ? (r.recognized() ? "" : "refused") : r.accepted_by();
  return fmt::format("{},{},{},{}", path,
                     r.nfa_computed() ? fmt::format("{:.2f}", r.log10_nfa()) : "",
                     r.global_stage() ? fmt::format("{:.4f}", r.global_similarity()) : "",
                     r.global_model() ? fmt::format("{:.2f}", r.global_log10_false_alarms()) : "");
}

std::string RecognitionSummary(const v1::RecognizeResponse& response) {
  if (!response.recognized()) {
    return response.reason().empty() ? "not recognized"
                                     : fmt::format("not recognized: {}", response.reason());
  }
  const std::string position =
      response.position().empty() ? "" : fmt::format(", position {}", response.position());
  // Retrieval mode says why: the path that accepted the answer and its numbers.
  const std::string why = RecognitionWhy(response);
  const std::string sure = why.empty() ? "" : fmt::format(", {}", why);
  const std::string belief =
      response.has_evidence()
          ? fmt::format(", posterior {:.3f} over {} frames", response.evidence().posterior(),
                        response.evidence().frames())
          : "";
  return fmt::format("recognized {}, {}, decision {:.3f}{}{} (view {}{})", response.crossing(),
                     HeadingText(response.heading_deg()), response.decision(), sure, belief,
                     response.view_id(), position);
}

std::string RecognitionDetails(const v1::RecognizeResponse& response) {
  const v1::StageTimings& t = response.timings();
  const std::string retrieval =
      t.retrieval_ms() > 0 ? fmt::format(", global stage {:.1f}", t.retrieval_ms()) : "";
  return fmt::format(
      "{} mode, keypoints {}, qualifying clusters {}, server {:.1f} ms (decode {:.1f}, extraction "
      "{:.1f}, matching {:.1f}{}, histogram {:.1f}, verification {:.1f})",
      ModeName(response.mode()), response.keypoints(), response.qualifying_clusters(), t.total_ms(),
      t.decode_ms(), t.extraction_ms(), t.matching_ms(), retrieval, t.histogram_ms(),
      t.verification_ms());
}

void PrintCandidateTable(std::ostream& out, const v1::RecognizeResponse& response) {
  if (response.candidates().empty()) {
    out << "  (no candidates)\n";
    return;
  }
  const bool verified = response.mode() == v1::RECOGNITION_MODE_VERIFIED;
  // Retrieval mode judges match sets too, and says how sure: NFA and global similarity.
  const bool retrieval = response.mode() == v1::RECOGNITION_MODE_RETRIEVAL;
  const bool geometric = verified || retrieval;
  // Capture positions get a column when some view has one (databases enrolled with positions).
  const bool positions =
      std::any_of(response.candidates().begin(), response.candidates().end(),
                  [](const v1::Candidate& c) { return !c.position().empty(); });
  // The position column goes after the heading.
  constexpr int kPositionColumn = 3;
  std::vector<Table::Column> columns = {{"view", true},
                                        {"crossing"},
                                        {"heading", true},
                                        {"cluster", true},
                                        {"centre"},
                                        {geometric ? "inliers" : "matches", true},
                                        {"tentative", true},
                                        {"similarity", true},
                                        {"decision", true}};
  if (retrieval) {
    columns.push_back({"log10 NFA", true});
    columns.push_back({"global", true});
  }
  columns.push_back({"best"});
  if (positions) columns.insert(columns.begin() + kPositionColumn, {"position"});
  Table table(std::move(columns));
  for (const v1::Candidate& c : response.candidates()) {
    const bool best = response.recognized() && c.view_id() == response.view_id();
    std::vector<std::string> row = {
        std::to_string(c.view_id()), c.crossing(),
        std::isnan(c.heading_deg()) ? "-" : fmt::format("{:.1f}", c.heading_deg()),
        std::to_string(c.cluster_id()), c.is_center() ? "yes" : "", std::to_string(c.matches()),
        geometric ? std::to_string(c.tentative()) : "-",
        c.kept() ? fmt::format("{:.3f}", c.similarity()) : "-",
        c.kept() ? fmt::format("{:.3f}", c.decision()) : "-"};
    if (retrieval) {
      row.push_back(fmt::format("{:.1f}", c.log10_nfa()));
      row.push_back(c.global_similarity() > 0 ? fmt::format("{:.3f}", c.global_similarity())
                                              : "-");
    }
    row.push_back(best ? "<=" : "");
    if (positions) row.insert(row.begin() + kPositionColumn, c.position());
    table.AddRow(std::move(row));
  }
  table.Print(out);
}

}  // namespace waymark::cli
