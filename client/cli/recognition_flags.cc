#include "client/cli/recognition_flags.h"

namespace waymark::cli {
namespace {

bool Given(const CLI::Option* option) { return option != nullptr && option->count() > 0; }

}  // namespace

CLI::Option* AddModeOption(CLI::App* command, std::string* mode) {
  return command
      ->add_option("--mode", *mode,
                   "paper: the paper's method exactly; verified: geometric verification and a "
                   "calibrated rejection rule; retrieval: acceptance by the expected number of "
                   "false alarms, and evidence over a stream's frames")
      ->transform(CLI::IsMember({"paper", "verified", "retrieval"}, CLI::ignore_case));
}

v1::RecognitionMode ModeFromName(const std::string& name) {
  if (name == "paper") return v1::RECOGNITION_MODE_PAPER;
  if (name == "verified") return v1::RECOGNITION_MODE_VERIFIED;
  if (name == "retrieval") return v1::RECOGNITION_MODE_RETRIEVAL;
  return v1::RECOGNITION_MODE_UNSPECIFIED;
}

void RecognitionFlags::Register(CLI::App* command) {
  const std::string group = "Recognition overrides (default: the database's values)";
  mode_option_ = AddModeOption(command, &mode_)->group(group);
  ratio_option_ = command->add_option("--ratio", ratio_, "Lowe ratio lambda, in (0, 1]")
                      ->check(CLI::Range(0.0, 1.0))
                      ->group(group);
  n0_option_ = command->add_option("--n0", n0_, "Min matches for a cluster centre to qualify")
                   ->check(CLI::NonNegativeNumber)
                   ->group(group);
  n1_option_ =
      command->add_option("--n1", n1_, "Min matches for a cluster member to enter the list")
          ->check(CLI::NonNegativeNumber)
          ->group(group);
  n2_option_ = command->add_option("--n2", n2_, "Views kept for the hue histogram step")
                   ->check(CLI::PositiveNumber)
                   ->group(group);
  alpha_option_ = command->add_option("--alpha", alpha_, "Weight of matches in the decision")
                      ->check(CLI::Range(0.0, 1.0))
                      ->group(group);
  beta_option_ = command->add_option("--beta", beta_, "Weight of hue similarity in the decision")
                     ->check(CLI::Range(0.0, 1.0))
                     ->group(group);
  min_inliers_option_ =
      command->add_option("--min-inliers", min_inliers_, "Verified mode: inliers to accept")
          ->check(CLI::NonNegativeNumber)
          ->group(group);
  max_log10_nfa_option_ =
      command
          ->add_option("--max-log10-nfa", max_log10_nfa_,
                       "Retrieval mode: accept when chance would match fewer than 10^X views as "
                       "well [0]")
          ->check(CLI::Range(-10000.0, 100.0))
          ->group(group);
  global_shortlist_option_ =
      command
          ->add_option("--global-shortlist", global_shortlist_,
                       "Retrieval mode: views most similar by global descriptor that are verified "
                       "too [24]")
          ->check(CLI::Range(0, 1000))
          ->group(group);
  min_global_lift_option_ =
      command
          ->add_option("--min-global-lift", min_global_lift_,
                       "Retrieval mode, legacy lift rule: accept the most similar view when it "
                       "stands this far above the median global similarity; 0 = off, the global "
                       "chance model decides [0]")
          ->check(CLI::Range(0.0, 2.0))
          ->group(group);
  max_log10_global_efa_option_ =
      command
          ->add_option("--max-log10-global-efa", max_log10_global_efa_,
                       "Retrieval mode, global path: accept when its chance model expects fewer "
                       "than 10^X views of other places as similar [-2]")
          ->check(CLI::Range(-10000.0, 100.0))
          ->group(group);
  evidence_option_ =
      command
          ->add_option("--evidence", evidence_,
                       "Retrieval mode, streams: posterior over the frames a crossing needs; 0 = "
                       "every frame on its own [0.95]")
          ->check(CLI::Range(0.0, 0.999999))
          ->group(group);
}

v1::RecognitionParams RecognitionFlags::ToParams() const {
  v1::RecognitionParams params;
  if (Given(mode_option_)) params.set_mode(ModeFromName(mode_));
  if (Given(ratio_option_)) params.set_ratio(ratio_);
  if (Given(n0_option_)) params.set_n0(n0_);
  if (Given(n1_option_)) params.set_n1(n1_);
  if (Given(n2_option_)) params.set_n2(n2_);
  if (Given(alpha_option_)) params.set_alpha(alpha_);
  if (Given(beta_option_)) params.set_beta(beta_);
  if (Given(min_inliers_option_)) params.set_min_inliers(min_inliers_);
  if (Given(max_log10_nfa_option_)) params.set_max_log10_nfa(max_log10_nfa_);
  if (Given(evidence_option_)) params.set_evidence_threshold(evidence_);
  if (Given(global_shortlist_option_)) params.set_global_shortlist(global_shortlist_);
  if (Given(min_global_lift_option_)) params.set_min_global_lift(min_global_lift_);
  if (Given(max_log10_global_efa_option_)) {
    params.set_max_log10_global_efa(max_log10_global_efa_);
  }
  return params;
}

}  // namespace waymark::cli
