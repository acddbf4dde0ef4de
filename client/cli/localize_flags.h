#ifndef WAYMARK_CLIENT_CLI_LOCALIZE_FLAGS_H_
#define WAYMARK_CLIENT_CLI_LOCALIZE_FLAGS_H_

// `--localize-on SESSION [--initial-pose X,Y,THETA]`, shared by `slam replay` and `robot`: the
// laser session they create localizes on a stored map (LaserSlamConfig.localize) instead of
// mapping.

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// Registers the two flags on `command`: `*config` is set when --localize-on is given, with
// initial_pose from --initial-pose (which needs --localize-on; a bad pose is a usage error).
// `config` must outlive the parse (CLI11 keeps the pointer). Returns the --localize-on option.
CLI::Option* AddLocalizeFlags(CLI::App* command, std::optional<v1::LocalizationConfig>* config);

// "X,Y,THETA" (metres, metres, radians) as a pose; INVALID_ARGUMENT naming the form otherwise.
absl::StatusOr<v1::Pose2D> ParsePoseText(const std::string& text);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_LOCALIZE_FLAGS_H_
