#ifndef WAYMARK_CLIENT_CLI_RECOGNITION_OUTPUT_H_
#define WAYMARK_CLIENT_CLI_RECOGNITION_OUTPUT_H_

#include <ostream>
#include <string>

#include "waymark/v1/crossing.pb.h"

namespace waymark::cli {

// Human-readable recognition results, shared by `recognize` (files and camera) and `eval`.

// "recognized A, heading 30.0 deg, decision 0.873 (view 12)" (", position north-kerb" after the
// view when it has one) or "not recognized: <reason>".
std::string RecognitionSummary(const v1::RecognizeResponse& response);

// Why the answer is what it is (issue 34): the path that accepted it (or "refused") and its
// numbers: "accepted by global: similarity 0.412, 10^-3.1 false alarms by chance; no geometric
// match set (NFA not computed)". Empty for a paper- or verified-mode answer without them.
std::string RecognitionWhy(const v1::RecognizeResponse& response);

// The answer's path and numbers as CSV: RecognitionCsvHeader() names the columns
// (accepted_by,log10_nfa,global_similarity,global_log10_false_alarms); a number that was not
// computed is an empty field, never 0.
std::string RecognitionCsvHeader();
std::string RecognitionCsvFields(const v1::RecognizeResponse& response);

// "keypoints 512, qualifying clusters 3, server 45.1 ms (decode 1.2, extraction 30.1, ...)".
std::string RecognitionDetails(const v1::RecognizeResponse& response);

// The candidate list as in the paper's Table 1: view, crossing, heading (and capture position when
// a view has one), matches, similarity, decision (similarity and decision only for the views the
// histogram step saw).
void PrintCandidateTable(std::ostream& out, const v1::RecognizeResponse& response);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_RECOGNITION_OUTPUT_H_
