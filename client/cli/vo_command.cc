#include "client/cli/vo_command.h"

#include <memory>
#include <optional>
#include <string>

#include "client/datasets/image_sequence.h"
#include "client/sessions/vo_session.h"

namespace waymark::cli {
namespace {

void AddNumber(CLI::App* command, const std::string& name, std::optional<double>* target,
               const std::string& help) {
  command
      ->add_option_function<double>(
          name, [target](const double& value) { *target = value; }, help)
      ->check(CLI::PositiveNumber);
}

// An option beyond the paper: unset leaves the preset's value (the server fills it per input kind).
template <typename T>
void AddBeyondPaper(CLI::App* command, const std::string& name, std::optional<T>* target, T lowest,
                    T highest, const std::string& help) {
  command->add_option(name, *target, help)->check(CLI::Range(lowest, highest));
}

}  // namespace

void AddVoCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* vo = app.add_subcommand("vo", "Visual odometry sessions (camera frames)");
  vo->require_subcommand(1);

  auto args = std::make_shared<VoArgs>();
  CLI::App* run = vo->add_subcommand(
      "run",
      "Stream an image sequence (TUM layout: rgb.txt / associations.txt; KITTI layout: image_0/ + "
      "calib.txt) into a new visual session; write trajectory.txt (TUM), trajectory.svg and "
      "trajectory.png (the path from above, with the aligned ground truth when there is one), "
      "frames/NNNNNN.png (features: static green, static in a box blue, dynamic red, potentially "
      "dynamic yellow, unmatched grey) and summary.json (with ATE/RPE when the folder has "
      "groundtruth.txt or poses.txt)");
  run->add_option("SEQ_DIR", args->sequence,
                  "Sequence folder, or a ROS bag (ROS 1 .bag, rosbag2 folder or .db3, MCAP) with a "
                  "sensor_msgs/Image or CompressedImage topic (intrinsics from its CameraInfo)")
      ->required();
  run->add_option("--image-topic", args->image_topic,
                  "Bags: the Image or CompressedImage topic (default: the bag's only one)");
  run->add_option("--detector", args->detector,
                  "Movable-object detector: none, hog (OpenCV people detector), "
                  "yolo:CFG,WEIGHTS (darknet) or yolo:MODEL.onnx; model files are uploaded")
      ->capture_default_str();
  run->add_flag("--paper", args->paper,
                "The paper's pipeline exactly (the session preset PRESET_PAPER: the full filter and "
                "the paper's constants) instead of the default, the best configuration measured "
                "per input kind (docs/visual-odometry.md, \"Defaults\"); flags given still apply");
  run->add_option("--filter", args->filter,
                  "Dynamic-point filter: full (the paper: boxes + static test), boxes (drop "
                  "features in boxes), none (plain ORB VO) or proven (full, and boxed features "
                  "static over several frames are used like the rest); default: the preset's "
                  "(proven; --paper: full)")
      ->check(CLI::IsMember({"full", "boxes", "none", "proven"}));
  AddBeyondPaper(run, "--prior-direction", &args->prior_direction_deg, 0.0, 180.0,
                 "Monocular motion prior: a motion this many degrees off the constant-velocity "
                 "prediction gives way to it when the pairs cannot tell them apart (default 30, "
                 "measured best on KITTI; 0 = off, the paper)");
  AddBeyondPaper(run, "--bundle-window", &args->bundle_window, 0, 50,
                 "Local bundle adjustment over this many keyframes, in the background (default: "
                 "10 monocular, off RGB-D, as measured best; 0 = off, the paper)");
  AddBeyondPaper(run, "--relocalize", &args->relocalize, 0, 1000,
                 "Keep this many keyframes (monocular: one frame in five) that left the local "
                 "map and relocalise a frame that cannot be tracked against them (0 or unset = "
                 "off, the paper)");
  AddBeyondPaper(run, "--static-hamming", &args->static_hamming, 0.01, 1.0,
                 "The static test's descriptor half as a fraction of delta (default 1.0 = geometry "
                 "only, measured best with --filter proven; 0.5 = the paper)");
  AddBeyondPaper(run, "--proven-frames", &args->proven_frames, 1, 1000,
                 "--filter proven: frames in a row a boxed feature must be static before it is "
                 "used like the rest (default 2, measured best; the paper's preset 3)");
  run->add_option("--movable", args->movable,
                  "Movable classes, comma-separated (default: the server's person,car,bus,truck,"
                  "bicycle,motorbike)");
  run->add_flag("--depth", args->depth, "Send the depth frames too (RGB-D: metric poses)");
  run->add_option(
      "--camera", args->camera,
      "Camera preset: " + CameraPresetNames() + " (TUM-layout folders have no calibration file)");
  AddNumber(run, "--fx", &args->fx, "Focal length x (pixels)");
  AddNumber(run, "--fy", &args->fy, "Focal length y (pixels)");
  AddNumber(run, "--cx", &args->cx, "Principal point x (pixels)");
  AddNumber(run, "--cy", &args->cy, "Principal point y (pixels)");
  run->add_option("--distortion", args->distortion, "k1,k2,p1,p2[,k3] (OpenCV order)");
  AddNumber(run, "--depth-scale", &args->depth_scale,
            "Depth image units per metre (TUM, Bonn: 5000)");
  run->add_option("--max-frames", args->max_frames, "Send at most N frames (0 = all)")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--out", args->out_dir, "Output folder (default ./out/vo-<sequence name>)");
  run->add_option("--robot", args->robot_id, "Robot id of the session")->capture_default_str();
  run->add_option("--name", args->name, "Session name (default 'vo run <sequence name>')");
  run->add_option("--window", args->window, "Frames in flight at most")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  run->add_option("--sample-every", args->sample_every,
                  "Feature picture of every N-th frame sent (0 = only the most dynamic frame)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  run->add_option("--reconnect-seconds", args->reconnect_seconds,
                  "A broken stream is reopened on the same session (resending the frames not "
                  "answered) until no frame has been answered for this long")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  registry.Add(run, [args](CommandContext& c) { return RunVo(c, *args); });
}

}  // namespace waymark::cli
