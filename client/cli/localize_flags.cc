#include "client/cli/localize_flags.h"

#include <cmath>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace waymark::cli {

absl::StatusOr<v1::Pose2D> ParsePoseText(const std::string& text) {
  const std::vector<absl::string_view> parts = absl::StrSplit(text, ',');
  std::vector<double> values;
  for (absl::string_view part : parts) {
    double value = 0;
    if (absl::SimpleAtod(part, &value) && std::isfinite(value)) values.push_back(value);
  }
  if (parts.size() != 3 || values.size() != 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "expected X,Y,THETA (metres, metres, radians; e.g. 1.5,-2,0.3), got '", text, "'"));
  }
  v1::Pose2D pose;
  pose.set_x(values[0]);
  pose.set_y(values[1]);
  pose.set_theta(values[2]);
  return pose;
}

CLI::Option* AddLocalizeFlags(CLI::App* command, std::optional<v1::LocalizationConfig>* config) {
  CLI::Option* localize_on = command->add_option_function<std::string>(
      "--localize-on",
      [config](const std::string& session) {
        if (!config->has_value()) config->emplace();
        (*config)->set_map_session_id(session);
      },
      "Localize on this stored map (a closed laser session with loop closure, or one made by "
      "`slam import-map`) instead of mapping");
  command
      ->add_option_function<std::string>(
          "--initial-pose",
          [config](const std::string& text) {
            absl::StatusOr<v1::Pose2D> pose = ParsePoseText(text);
            if (!pose.ok())
              throw CLI::ValidationError("--initial-pose", std::string(pose.status().message()));
            if (!config->has_value()) config->emplace();
            *(*config)->mutable_initial_pose() = *pose;
          },
          "Where the robot starts in the map: X,Y,THETA (m, m, rad); without it the server "
          "searches "
          "the whole map for the first fix")
      ->needs(localize_on);
  return localize_on;
}

}  // namespace waymark::cli
