// waymark-vo-bench: the visual odometry engine (METHODS.md section 3) on a real sequence, without
// the server: accuracy (ATE/RPE against the sequence's ground truth) and milliseconds per frame by
// stage, for several filter/detector configurations in one run (same frames, same machine, so the
// rows compare).
//
//   waymark-vo-bench SEQ_DIR [--camera bonn|tum1|tum2|tum3|kitti] [--no-depth]
//       [--configs none,boxes:yolo,full:yolo] [--models ../shared/models/yolo-fastest-1.1-coco]
//       [--frames N] [--threads N] [--hypotheses N] [--rounds N] [--features N]
//
// A configuration is FILTER[:DETECTOR]: FILTER none (plain ORB VO, every feature used), boxes
// (every feature in a box dropped), full (the paper's method), proven (full, and boxed features
// static over several frames are tracked and mapped); DETECTOR none, yolo or hog. An optional
// third part, join or nojoin, sets join_static_boxed for that configuration (proven:yolo:nojoin is
// the proven filter before issue 35's fix), whatever the preset says.
// Frames are decoded before timing. Monocular runs (KITTI, or --no-depth) are scale-free and
// aligned with scale (Sim(3)); RGB-D runs rigidly (SE(3)). The load average is printed: on a
// shared machine it says how much to trust the times. No asserts.

#include <stdlib.h>
#include <time.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_split.h"
#include "bench/common/bench_timing.h"
#include "client/datasets/image_sequence.h"
#include "client/eval/trajectory_metrics.h"
#include "server/visual_slam/detectors/detector_factory.h"
#include "server/visual_slam/visual_odometry.h"

namespace waymark::bench {
namespace {

namespace fs = std::filesystem;
namespace vs = visual_slam;

struct Config {
  std::string name;
  vs::DynamicFilter filter = vs::DynamicFilter::kFull;
  vs::DetectorChoice::Kind detector = vs::DetectorChoice::kNone;
  std::optional<bool> join;  // join_static_boxed when given (third part: join | nojoin)
};

bool ParseConfig(const std::string& text, Config& out) {
  std::vector<std::string> parts = absl::StrSplit(text, ':');
  out.name = text;
  if (parts[0] == "none")
    out.filter = vs::DynamicFilter::kNone;
  else if (parts[0] == "boxes")
    out.filter = vs::DynamicFilter::kBoxesOnly;
  else if (parts[0] == "full")
    out.filter = vs::DynamicFilter::kFull;
  else if (parts[0] == "proven")
    out.filter = vs::DynamicFilter::kProven;
  else
    return false;
  const std::string detector = parts.size() > 1 ? parts[1] : "none";
  if (detector == "none")
    out.detector = vs::DetectorChoice::kNone;
  else if (detector == "yolo")
    out.detector = vs::DetectorChoice::kYolo;
  else if (detector == "hog")
    out.detector = vs::DetectorChoice::kHog;
  else
    return false;
  if (parts.size() > 2) {
    if (parts[2] == "join")
      out.join = true;
    else if (parts[2] == "nojoin")
      out.join = false;
    else
      return false;
  }
  return parts.size() <= 3;
}

struct Decoded {
  double stamp;
  cv::Mat image, depth;
};

int Run(int argc, char** argv) {
  CLI::App app{"Visual odometry engine: accuracy and ms per stage on a real sequence"};
  std::string dir, camera_name, configs_text = "none,boxes:yolo,full:yolo";
  std::string models = std::string(WAYMARK_SOURCE_DIR) + "/../shared/models/yolo-fastest-1.1-coco";
  bool no_depth = false;
  int max_frames = 0, threads = -1;
  visual_slam::VisualOdometryOptions base;
  app.add_option("SEQ_DIR", dir, "TUM/Bonn or KITTI layout")->required();
  app.add_option("--camera", camera_name, "intrinsics preset (KITTI reads calib.txt)");
  app.add_flag("--no-depth", no_depth, "monocular even when depth is listed");
  app.add_option("--configs", configs_text, "comma-separated FILTER[:DETECTOR[:join|nojoin]]");
  app.add_option("--models", models, "folder with yolo-fastest-1.1-xl.cfg/.weights");
  app.add_option("--frames", max_frames, "at most N frames (0 = all)");
  app.add_option("--threads", threads, "cv::setNumThreads (-1 = OpenCV's default)");
  app.add_option("--hypotheses", base.sampler.hypotheses_per_round, "sampler hypotheses per round")
      ->capture_default_str();
  app.add_option("--rounds", base.sampler.max_rounds, "sampler rounds")->capture_default_str();
  app.add_option("--features", base.orb.features, "ORB features per frame")->capture_default_str();
  app.add_option("--static-hamming", base.static_hamming_fraction,
                 "eq 17's descriptor half as a fraction of delta (paper 0.5)")
      ->capture_default_str();
  app.add_option("--bundle-window", base.bundle_window,
                 "local bundle adjustment over this many keyframes (0 = off, the paper)")
      ->capture_default_str();
  app.add_flag("--bundle-wait", base.bundle_wait,
               "apply each adjustment before the next frame (deterministic)");
  app.add_option("--relocalize", base.relocalization_keyframes,
                 "RGB-D: archived keyframes to relocalise against (0 = off)")
      ->capture_default_str();
  app.add_option("--prior-direction", base.prior_direction_deg,
                 "monocular motion prior: max degrees from the predicted direction (0 = off)")
      ->capture_default_str();
  app.add_option("--proven-frames", base.proven_static_frames,
                 "proven filter: frames in a row a boxed feature must be static")
      ->capture_default_str();
  int seeds = 1;
  app.add_option("--seeds", seeds,
                 "runs per config with sampler seeds 1..N; ATE/RPE/lost are "
                 "the median over runs, ATE's min-max is printed")
      ->capture_default_str();
  int yolo_input = 0;
  app.add_option("--yolo-input", yolo_input,
                 "YOLO network input side in pixels, a multiple of 32 (0 = the cfg's, 320)");
  bool realtime = false;
  app.add_flag("--realtime", realtime,
               "feed frames at the sequence's own rate (its stamps), as a camera does, instead of "
               "back to back; an adjustment applied when done then lags as it would on a robot");
  std::string preset = "paper";
  app.add_option("--preset", preset,
                 "paper (the paper's constants; the flags above change them) or best (the "
                 "service's default, VisualOdometryOptions::MeasuredBest; flags given win)")
      ->check(CLI::IsMember({"paper", "best"}))
      ->capture_default_str();
  int start = 0, stride = 1;
  app.add_option("--start", start, "skip the first N frames")->capture_default_str();
  app.add_option("--stride", stride, "use every N-th frame (a faster camera motion per frame)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  std::string per_frame_path;
  app.add_option("--per-frame", per_frame_path,
                 "CSV of every frame's feature counts and state (config, seed, frame, ...)");
  CLI11_PARSE(app, argc, argv);
  if (preset == "best") {
    const vs::VisualOdometryOptions best = vs::VisualOdometryOptions::MeasuredBest();
    if (app.count("--static-hamming") == 0) base.static_hamming_fraction = best.static_hamming_fraction;
    if (app.count("--proven-frames") == 0) base.proven_static_frames = best.proven_static_frames;
    base.join_static_boxed = best.join_static_boxed;
    if (app.count("--prior-direction") == 0) base.prior_direction_deg = best.prior_direction_deg;
    if (app.count("--bundle-window") == 0) {
      base.bundle_window = best.bundle_window;
      base.bundle_monocular_only = best.bundle_monocular_only;
    }
  }
  std::FILE* per_frame = nullptr;
  if (!per_frame_path.empty()) {
    per_frame = std::fopen(per_frame_path.c_str(), "w");
    if (per_frame == nullptr) {
      std::fprintf(stderr, "cannot write %s\n", per_frame_path.c_str());
      return 1;
    }
    std::fprintf(per_frame,
                 "config,seed,frame,state,total,boxed,matched,dynamic,tracked,mapped,"
                 "proven,boxes,bundle_ms,tx,ty,tz,r00,r01,r02,r10,r11,r12,r20,r21,r22,"
                 "static_in_box,inliers,parallax_deg,quality\n");
  }
  if (threads >= 0) cv::setNumThreads(threads);

  absl::StatusOr<cli::ImageSequence> sequence = cli::ReadImageSequence(dir);
  if (!sequence.ok()) {
    std::fprintf(stderr, "%s\n", sequence.status().ToString().c_str());
    return 1;
  }
  std::optional<cli::CameraIntrinsics> intrinsics = sequence->intrinsics;
  if (!camera_name.empty()) {
    absl::StatusOr<cli::CameraIntrinsics> preset = cli::CameraPreset(camera_name);
    if (!preset.ok()) {
      std::fprintf(stderr, "%s\n", preset.status().ToString().c_str());
      return 1;
    }
    intrinsics = *preset;
  }
  if (!intrinsics) {
    std::fprintf(stderr, "no intrinsics: give --camera %s\n", cli::CameraPresetNames().c_str());
    return 1;
  }
  std::vector<Decoded> frames;
  for (size_t i = static_cast<size_t>(std::max(0, start)); i < sequence->frames.size();
       i += static_cast<size_t>(stride)) {
    const cli::SequenceFrame& f = sequence->frames[i];
    if (max_frames > 0 && static_cast<int>(frames.size()) >= max_frames) break;
    Decoded d{f.stamp, cv::imread(f.image.string(), cv::IMREAD_COLOR), cv::Mat()};
    if (f.depth && !no_depth) d.depth = cv::imread(f.depth->string(), cv::IMREAD_UNCHANGED);
    frames.push_back(std::move(d));
  }
  if (frames.empty()) return 1;
  const bool rgbd = !frames[0].depth.empty();
  vs::CameraModel camera;
  camera.fx = intrinsics->fx;
  camera.fy = intrinsics->fy;
  camera.cx = intrinsics->cx;
  camera.cy = intrinsics->cy;
  camera.distortion = intrinsics->distortion;
  camera.width = frames[0].image.cols;
  camera.height = frames[0].image.rows;
  absl::StatusOr<std::vector<cli::StampedPose3>> groundtruth =
      cli::ReadSequenceGroundTruth(*sequence);

  std::printf("%s: %zu frames %dx%d, %s, load average %s\n", dir.c_str(), frames.size(),
              camera.width, camera.height, rgbd ? "RGB-D" : "monocular", LoadAverageText().c_str());
  std::printf("%-12s %8s %8s %8s %5s | median ms: %6s %6s %6s %6s %6s %6s %6s | p90 total  cpu\n",
              "config", "ATE m", "RPEt m", "RPEr deg", "lost", "orb", "detect", "match", "sample",
              "pose", "map", "total");
  for (const std::string& text : std::vector<std::string>(absl::StrSplit(configs_text, ','))) {
    Config config;
    if (!ParseConfig(text, config)) {
      std::fprintf(stderr,
                   "bad config '%s' (FILTER[:DETECTOR[:join|nojoin]], none|boxes|full|proven, "
                   "none|yolo|hog)\n",
                   text.c_str());
      return 1;
    }
    std::vector<double> orb, det, match, sample, pose, map, total, ates, rpes_t, rpes_r, losts;
    std::vector<double> state_bytes;  // the session's checkpoint (its map) at the end of a run
    std::vector<double> session_mb;   // resident memory the session added by the end of a run
    std::vector<double> bundle, bundle_wait;  // per adjustment applied: its time, the frame's wait
    double cpu_ms = 0;
    int frames_run = 0;
    for (int seed = 1; seed <= seeds; ++seed) {
      vs::DetectorChoice choice;
      choice.kind = config.detector;
      if (config.detector == vs::DetectorChoice::kYolo) {
        choice.yolo.cfg = ReadFileBytes(fs::path(models) / "yolo-fastest-1.1-xl.cfg");
        choice.yolo.weights = ReadFileBytes(fs::path(models) / "yolo-fastest-1.1-xl.weights");
        choice.yolo.input_size = yolo_input;
      }
      const double resident_before = ResidentMb();
      absl::StatusOr<std::unique_ptr<vs::ObjectDetector>> detector = vs::MakeDetector(choice);
      if (!detector.ok()) {
        std::fprintf(stderr, "%s: %s\n", text.c_str(), detector.status().ToString().c_str());
        return 1;
      }
      vs::VisualOdometryOptions options = base;
      options.filter = config.filter;
      if (config.join) options.join_static_boxed = *config.join;
      options.sampler.seed = seed;
      options.depth_scale = intrinsics->depth_scale > 0 ? intrinsics->depth_scale : 5000;
      absl::StatusOr<std::unique_ptr<vs::VisualOdometry>> odometry =
          vs::VisualOdometry::Create(options, camera, *std::move(detector));
      if (!odometry.ok()) {
        std::fprintf(stderr, "%s\n", odometry.status().ToString().c_str());
        return 1;
      }
      int lost = 0;
      int frame_index = -1;
      const double cpu_start = ProcessCpuMs();
      const auto run_start = std::chrono::steady_clock::now();
      for (const Decoded& f : frames) {
        if (realtime) {
          std::this_thread::sleep_until(
              run_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(f.stamp - frames[0].stamp)));
        }
        vs::FrameInput input{f.stamp, f.image, f.depth, std::nullopt};
        absl::StatusOr<vs::FrameResult> r = (*odometry)->ProcessFrame(input);
        ++frame_index;
        if (!r.ok()) {
          std::fprintf(stderr, "frame %.6f: %s\n", f.stamp, r.status().ToString().c_str());
          continue;
        }
        if (per_frame != nullptr) {
          const vs::FeatureCounts& c = r->counts;
          const vs::Pose& p = r->pose;
          const int static_in_box = static_cast<int>(std::count(
              r->labels.begin(), r->labels.end(), vs::FeatureLabel::kStaticInBox));
          std::fprintf(
              per_frame,
              "%s,%d,%d,%d,%d,%d,%d,%d,%d,%d,%d,%zu,%.2f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,"
              "%.9f,%.9f,%.9f,%.9f,%.9f,%d,%d,%.4f,%s\n",
              text.c_str(), seed, frame_index, static_cast<int>(r->state), c.total,
              c.potentially_dynamic, c.matched, c.dynamic, c.tracked, c.mapped, c.proven,
              r->boxes.size(), r->timings.bundle_ms, p.t.x(), p.t.y(), p.t.z(), p.R(0, 0),
              p.R(0, 1), p.R(0, 2), p.R(1, 0), p.R(1, 1), p.R(1, 2), p.R(2, 0), p.R(2, 1),
              p.R(2, 2), static_in_box, r->quality.inliers, r->quality.parallax_deg,
              vs::QualityLevelName(r->quality.level));
        }
        ++frames_run;
        lost += r->state == vs::TrackingState::kLost;
        orb.push_back(r->timings.orb_ms);
        det.push_back(r->timings.detector_ms);
        match.push_back(r->timings.matching_ms);
        sample.push_back(r->timings.sampling_ms);
        pose.push_back(r->timings.pose_ms);
        map.push_back(r->timings.mapping_ms);
        total.push_back(r->timings.total_ms);
        if (r->timings.bundle_ms > 0) {
          bundle.push_back(r->timings.bundle_ms);
          bundle_wait.push_back(r->timings.bundle_wait_ms);
        }
      }
      cpu_ms += ProcessCpuMs() - cpu_start;
      state_bytes.push_back(static_cast<double>((*odometry)->SerializeState().size()));
      session_mb.push_back(ResidentMb() - resident_before);
      losts.push_back(lost);
      if (groundtruth.ok()) {
        std::vector<cli::StampedPose3> estimate;
        for (const vs::TimedPose& p : (*odometry)->trajectory()) {
          estimate.push_back({p.stamp, p.pose.R, p.pose.t});
        }
        cli::TrajectoryOptions evaluation_options;
        evaluation_options.with_scale = !rgbd;
        absl::StatusOr<cli::TrajectoryEvaluation> e =
            cli::EvaluateTrajectory(estimate, *groundtruth, evaluation_options);
        if (e.ok()) {
          ates.push_back(e->ate.rmse);
          rpes_t.push_back(e->rpe_translation.rmse);
          rpes_r.push_back(e->rpe_rotation_deg.rmse);
        }
      }
    }
    const double cpu_per_frame = frames_run > 0 ? cpu_ms / frames_run : 0;
    const double ate = ates.empty() ? -1 : Percentile(ates, 0.5);
    const double rpe_t = rpes_t.empty() ? -1 : Percentile(rpes_t, 0.5);
    const double rpe_r = rpes_r.empty() ? -1 : Percentile(rpes_r, 0.5);
    const int lost = static_cast<int>(Percentile(losts, 0.5));
    std::printf(
        "%-12s %8.4f %8.4f %8.3f %5d | %17.1f %6.1f %6.1f %6.1f %6.1f %6.1f %6.1f | %9.1f %5.1f\n",
        text.c_str(), ate, rpe_t, rpe_r, lost, Percentile(orb, 0.5), Percentile(det, 0.5),
        Percentile(match, 0.5), Percentile(sample, 0.5), Percentile(pose, 0.5),
        Percentile(map, 0.5), Percentile(total, 0.5), Percentile(total, 0.9), cpu_per_frame);
    std::printf(
        "%-12s checkpoint state at the end: %.0f KB; the session added %.1f MB resident "
        "(detector included; median over runs)\n",
        "", Percentile(state_bytes, 0.5) / 1024, Percentile(session_mb, 0.5));
    if (!bundle.empty()) {
      std::printf(
          "%-12s bundle adjustments: %zu, ms each median %.1f p90 %.1f (background); "
          "frames waited median %.1f p90 %.1f ms\n",
          "", bundle.size(), Percentile(bundle, 0.5), Percentile(bundle, 0.9),
          Percentile(bundle_wait, 0.5), Percentile(bundle_wait, 0.9));
    }
    if (ates.size() > 1) {
      std::printf("%-12s ATE over %zu seeds: min %.4f max %.4f\n", "", ates.size(),
                  *std::min_element(ates.begin(), ates.end()),
                  *std::max_element(ates.begin(), ates.end()));
    }
    std::fflush(stdout);
  }
  if (per_frame != nullptr) std::fclose(per_frame);
  std::printf("load average after: %s\n", LoadAverageText().c_str());
  return 0;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) { return waymark::bench::Run(argc, argv); }
