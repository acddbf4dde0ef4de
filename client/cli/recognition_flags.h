#ifndef WAYMARK_CLIENT_CLI_RECOGNITION_FLAGS_H_
#define WAYMARK_CLIENT_CLI_RECOGNITION_FLAGS_H_

#include <CLI/CLI.hpp>
#include <string>

#include "waymark/v1/crossing.pb.h"

namespace waymark::cli {

// Adds `--mode paper|verified` (case-insensitive) bound to `*mode`.
CLI::Option* AddModeOption(CLI::App* command, std::string* mode);
// "paper" -> RECOGNITION_MODE_PAPER, "verified" -> RECOGNITION_MODE_VERIFIED, else UNSPECIFIED.
v1::RecognitionMode ModeFromName(const std::string& name);

// The per-request recognition overrides shared by `recognize` and `eval`. Only the options given on
// the command line are set in RecognitionParams, so everything else keeps the database's value.
// Must stay at a fixed address after Register() (CLI11 keeps pointers to the members).
class RecognitionFlags {
 public:
  void Register(CLI::App* command);
  v1::RecognitionParams ToParams() const;

 private:
  std::string mode_;
  double ratio_ = 0;
  int n0_ = 0;
  int n1_ = 0;
  int n2_ = 0;
  double alpha_ = 0;
  double beta_ = 0;
  int min_inliers_ = 0;
  double max_log10_nfa_ = 0;
  double evidence_ = 0;
  int global_shortlist_ = 0;
  double min_global_lift_ = 0;
  double max_log10_global_efa_ = 0;

  CLI::Option* mode_option_ = nullptr;
  CLI::Option* ratio_option_ = nullptr;
  CLI::Option* n0_option_ = nullptr;
  CLI::Option* n1_option_ = nullptr;
  CLI::Option* n2_option_ = nullptr;
  CLI::Option* alpha_option_ = nullptr;
  CLI::Option* beta_option_ = nullptr;
  CLI::Option* min_inliers_option_ = nullptr;
  CLI::Option* max_log10_nfa_option_ = nullptr;
  CLI::Option* evidence_option_ = nullptr;
  CLI::Option* global_shortlist_option_ = nullptr;
  CLI::Option* min_global_lift_option_ = nullptr;
  CLI::Option* max_log10_global_efa_option_ = nullptr;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_RECOGNITION_FLAGS_H_
