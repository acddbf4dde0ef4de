// `waymark eval ate TRAJECTORY GROUNDTRUTH`: absolute trajectory error after a rigid (Horn /
// Umeyama) alignment, or a similarity one with --scale, and relative pose error, of a TUM or KITTI
// trajectory against ground truth (trajectory_metrics.h, pose_file.h). Needs no server.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "client/cli/command.h"
#include "client/render/map_render.h"
#include "client/sessions/vo_pictures.h"
#include "client/common/output.h"
#include "client/datasets/pose_file.h"
#include "client/eval/trajectory_metrics.h"
#include "client/eval/result_warnings.h"
#include "client/eval/vo_summary.h"

namespace waymark::cli {
namespace {

struct AteArgs {
  std::string trajectory;
  std::string groundtruth;
  std::string format = "auto";
  std::string times;
  double max_dt = 0.02;
  bool scale = false;
  int delta = 1;
  std::string plot;
};

// Top view of the ground truth and the aligned estimate (each with start and end markers), in the
// plane of the two axes along which the ground truth extends most (x-z for a forward-moving
// camera, x-y for a robot).
// `mark`: NotMeaningfulMark's text, or "".
absl::Status WritePlot(const std::string& path, const TrajectoryEvaluation& result,
                       const std::string& mark) {
  const std::vector<Eigen::Vector3d>& gt = result.groundtruth_positions;
  Eigen::Vector3d lo = gt.front();
  Eigen::Vector3d hi = gt.front();
  for (const Eigen::Vector3d& p : gt) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = hi - lo;
  std::array<int, 3> axes = {0, 1, 2};
  std::sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });
  const int u = std::min(axes[0], axes[1]);
  const int v = std::max(axes[0], axes[1]);
  static constexpr const char* kAxis[] = {"x", "y", "z"};

  MapScene scene;
  scene.title = fmt::format(
      "ATE RMSE {:.4f} m over {} poses ({}-{} plane{}{})", result.ate.rmse,
      result.matches.size(), kAxis[u], kAxis[v],
      result.alignment.scale != 1.0 ? fmt::format(", scale {:.4f}", result.alignment.scale) : "",
      mark.empty() ? "" : ", " + mark);
  ScenePolyline truth{{}, Rgb{40, 40, 40}, 2.0, "ground truth", /*mark_ends=*/true};
  ScenePolyline estimate{{}, Rgb{220, 40, 40}, 1.5, "estimate (aligned)", /*mark_ends=*/true};
  for (const Eigen::Vector3d& p : gt) truth.points.push_back({p[u], p[v]});
  for (const Eigen::Vector3d& p : result.aligned_positions) {
    estimate.points.push_back({p[u], p[v]});
  }
  scene.references.push_back(std::move(truth));
  scene.polylines.push_back(std::move(estimate));
  // Drawn like `vo run`'s trajectory: no segment legend, centimetre motions still visible.
  return WriteDrawingFile(LayoutScene(scene, TrajectoryRenderOptions()), path);
}

int RunAte(CommandContext& context, const AteArgs& args) {
  absl::StatusOr<PoseFormat> format = ParsePoseFormat(args.format);
  if (!format.ok()) return ReportError(context, format.status(), "--format");
  if (!args.plot.empty()) {
    const std::string ext =
        absl::AsciiStrToLower(std::filesystem::path(args.plot).extension().string());
    if (ext != ".svg" && ext != ".png") {
      return ReportError(context,
                         absl::InvalidArgumentError("--plot needs a .svg or .png file name, got '" +
                                                    args.plot + "'"));
    }
  }
  PoseFileOptions options;
  options.format = *format;
  if (!args.times.empty()) {
    absl::StatusOr<std::vector<double>> stamps = ReadStampListFile(args.times);
    if (!stamps.ok()) return ReportError(context, stamps.status());
    options.kitti_stamps = *std::move(stamps);
  }
  absl::StatusOr<PoseFile> estimate = ReadPoseFile(args.trajectory, options);
  if (!estimate.ok()) return ReportError(context, estimate.status());
  absl::StatusOr<PoseFile> groundtruth = ReadPoseFile(args.groundtruth, options);
  if (!groundtruth.ok()) return ReportError(context, groundtruth.status());
  if (!args.times.empty() && estimate->format != PoseFormat::kKitti &&
      groundtruth->format != PoseFormat::kKitti) {
    return ReportError(context, absl::InvalidArgumentError(
                                    "--times gives stamps to KITTI pose files, but neither file "
                                    "is in KITTI format"));
  }

  TrajectoryOptions metric_options;
  metric_options.max_dt = args.max_dt;
  metric_options.with_scale = args.scale;
  metric_options.delta = args.delta;
  absl::StatusOr<TrajectoryEvaluation> result =
      EvaluateTrajectory(estimate->poses, groundtruth->poses, metric_options);
  if (!result.ok()) {
    return ReportError(context, result.status(),
                       fmt::format("{} against {}", args.trajectory, args.groundtruth));
  }
  // Every reason the numbers may mean nothing (result_warnings.h); --json marks them too.
  const std::vector<ResultWarning> warnings = EvaluationWarnings(*result, args.scale);
  for (const ResultWarning& warning : warnings) {
    context.err << "warning: " << warning.message << "\n";
  }
  // The score lines carry the mark themselves (the warnings are lines above them).
  const std::string mark = NotMeaningfulMark(warnings);
  if (!args.plot.empty()) {
    const std::string plot_mark = NotMeaningfulMark(warnings, "the run's warnings");
    if (absl::Status status = WritePlot(args.plot, *result, plot_mark); !status.ok()) {
      return ReportError(context, status);
    }
  }

  if (context.globals.json) {
    // The evaluation's fields are the ones `vo run` writes in summary.json (one list).
    nlohmann::json json = EvaluationSummary(*result, args.scale);
    json["trajectory"] = args.trajectory;
    json["groundtruth"] = args.groundtruth;
    json["trajectory_format"] = PoseFormatName(estimate->format);
    json["groundtruth_format"] = PoseFormatName(groundtruth->format);
    json["poses_estimated"] = result->poses_estimated;
    json["max_dt"] = args.max_dt;
    json["delta"] = args.delta;
    json["scale_estimated"] = args.scale;
    if (!args.plot.empty()) json["plot"] = args.plot;
    PrintJson(context.out, json);
    return kExitOk;
  }

  context.out << fmt::format(
      "{} poses matched ({} estimated, {} ground truth, within {} s); alignment {}{}{}\n",
      result->matches.size(), result->poses_estimated, result->poses_groundtruth, args.max_dt,
      args.scale ? "Sim(3)" : "SE(3)",
      args.scale ? fmt::format(", scale {:.6f}", result->alignment.scale) : "",
      mark.empty() ? "" : "; " + mark);
  Table table(
      {{"metric"}, {"rmse", true}, {"mean", true}, {"median", true}, {"std", true}, {"max", true}});
  auto row = [&](const std::string& name, const ErrorStats& s, int decimals) {
    table.AddRow({name, FormatNumber(s.rmse, decimals), FormatNumber(s.mean, decimals),
                  FormatNumber(s.median, decimals), FormatNumber(s.std, decimals),
                  FormatNumber(s.max, decimals)});
  };
  row(mark.empty() ? "ATE (m)" : "ATE (m), NOT MEANINGFUL", result->ate, 4);
  row(fmt::format("RPE trans (m, delta {})", args.delta), result->rpe_translation, 4);
  row(fmt::format("RPE rot (deg, delta {})", args.delta), result->rpe_rotation_deg, 3);
  table.Print(context.out);
  if (!args.plot.empty()) context.out << "plot: " << args.plot << "\n";
  return kExitOk;
}

}  // namespace

void AddEvalAteCommand(CLI::App& app, CommandRegistry& registry) {
  CLI::App* eval = app.get_subcommand("eval");
  auto args = std::make_shared<AteArgs>();
  CLI::App* ate = eval->add_subcommand(
      "ate",
      "Visual odometry accuracy: ATE after a rigid (Horn) alignment and RPE of TRAJECTORY against "
      "GROUNDTRUTH; TUM (t tx ty tz qx qy qz qw), KITTI (12 numbers, 3x4 [R|t]) or EuRoC "
      "(state_groundtruth_estimate0/data.csv: t [ns], p, q_w q_x q_y q_z, ...) pose files; warns "
      "when the result means nothing (Sim(3) scale outside [0.2, 5], ground truth under 0.1 m, "
      "a collapsed estimate; --json: warnings, result_meaningful); "
      "matched by time stamp");
  ate->add_option("TRAJECTORY", args->trajectory, "Estimated trajectory")->required();
  ate->add_option("GROUNDTRUTH", args->groundtruth, "Ground-truth trajectory")->required();
  ate->add_option("--format", args->format,
                  "Pose file format of both files: auto (by column count), tum, kitti or euroc")
      ->check(CLI::IsMember({"auto", "tum", "kitti", "euroc"}))
      ->capture_default_str();
  ate->add_option("--times", args->times,
                  "KITTI times.txt: stamps of the KITTI pose files (default: pose i at 0.1 * i "
                  "s, KITTI's 10 Hz, as `vo run` stamps a KITTI sequence without times.txt)");
  ate->add_option("--max-dt", args->max_dt, "Largest stamp difference (s) between matched poses")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  ate->add_flag("--scale", args->scale,
                "Also estimate the scale (Sim(3) alignment, for monocular trajectories)");
  ate->add_option("--delta", args->delta, "RPE over matched poses k and k + DELTA")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  ate->add_option("--plot", args->plot,
                  "Write a top view of ground truth and aligned estimate to FILE.svg or FILE.png");
  registry.Add(ate, [args](CommandContext& c) { return RunAte(c, *args); });
}

}  // namespace waymark::cli
