// `waymark vo run SEQ_DIR` (or a bag: its camera topic is written out as a sequence first, see
// client/ros/bag_images.h): streams an image sequence into a visual odometry session and writes
// what came back (see vo_session.h; the outputs are described in vo_command.cc's help).
//
// Frames are sent with at most --window unanswered (SensorStream's flow control), so a slow session
// never overflows the server's bounded queue. A broken stream (keepalive timeout, server restart)
// is reopened on the same session and the run goes on from the first frame not answered
// (resumable_frames.h); every frame is answered once.
//
// Every frame asks for per-feature data (want_features): which frame has the most dynamic features
// is only known afterwards, and the data (~9 bytes per feature, ~10 KB per frame) is small next to
// the image itself. Only the sample frames and the most dynamic one so far keep it.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/bags/bag_reader.h"
#include "client/common/read_file.h"
#include "client/ros/bag_images.h"
#include "client/ros/bag_path.h"
#include "client/render/vo_frames.h"
#include "client/sessions/resumable_frames.h"
#include "client/sessions/vo_pictures.h"
#include "client/sessions/vo_session.h"
#include "client/eval/result_warnings.h"
#include "client/eval/vo_summary.h"

namespace waymark::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr size_t kRejectionsPrinted = 20;

std::string SequenceName(const std::string& path) {
  fs::path p(path);
  if (p.filename().empty()) p = p.parent_path();
  const std::string name = p.filename().string();
  return name.empty() || name == "." ? "sequence" : name;
}

// The frames' size, from the first image's header.
absl::StatusOr<cv::Size> ImageSize(const fs::path& path) {
  try {
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("cannot decode '", path.string(), "' as an image"));
    }
    return image.size();
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("decoding '", path.string(), "': ", e.what()));
  }
}

// What the reader thread collects.
struct RunState {
  std::mutex mutex;
  std::vector<VoFrameRecord> records;  // one per frame sent, in send order
  std::set<size_t> sample_frames;      // send-order indices whose features are kept
  long best_dynamic = -1;              // send-order index of the most dynamic frame so far
  uint32_t best_dynamic_count = 0;
};

fs::path OutDir(const VoArgs& args) {
  return args.out_dir.empty() ? fs::path("out") / ("vo-" + SequenceName(args.sequence))
                              : fs::path(args.out_dir);
}

// The sequence folder, or a bag's camera topic written out as one into OUT/bag-frames
// (client/ros/bag_images.h), its intrinsics from the bag's CameraInfo.
absl::StatusOr<ImageSequence> OpenSequence(CommandContext& context, const VoArgs& args) {
  if (!ros::LooksLikeBag(args.sequence)) {
    if (!args.image_topic.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--image-topic chooses a bag's topic; '", args.sequence, "' is not a bag"));
    }
    return ReadImageSequence(args.sequence);
  }
  absl::StatusOr<std::unique_ptr<bags::BagReader>> reader = bags::OpenBag(args.sequence);
  if (!reader.ok()) return reader.status();
  const fs::path dir = OutDir(args) / "bag-frames";
  absl::StatusOr<ros::BagImages> images =
      ros::ExtractBagImages(*std::move(reader), args.image_topic, args.max_frames, dir);
  if (!images.ok()) {
    return absl::Status(images.status().code(),
                        absl::StrCat(args.sequence, ": ", images.status().message()));
  }
  for (const std::string& warning : images->warnings) context.err << "warning: " << warning << "\n";
  context.err << fmt::format(
      "vo: {} frames of {} written to {}{}\n", images->sequence.frames.size(), images->image_topic,
      dir.string(),
      images->sequence.intrinsics
          ? fmt::format(" (intrinsics from {})", images->camera_info_topic)
          : std::string(" (no CameraInfo intrinsics)"));
  return images->sequence;
}

}  // namespace

int RunVo(CommandContext& context, const VoArgs& args) {
  absl::StatusOr<ImageSequence> sequence = OpenSequence(context, args);
  if (!sequence.ok()) return ReportError(context, sequence.status());
  absl::StatusOr<CameraIntrinsics> camera = ResolveIntrinsics(args, *sequence);
  if (!camera.ok()) return ReportError(context, camera.status());
  if (args.depth && !sequence->has_depth_list) {
    return ReportError(context, absl::InvalidArgumentError(absl::StrCat(
                                    "--depth: '", args.sequence,
                                    "' has no depth frames (associations.txt or depth.txt)")));
  }
  if (args.depth && camera->depth_scale <= 0) {
    return ReportError(context, absl::InvalidArgumentError(
                                    "--depth needs --depth-scale (depth units per metre) or a "
                                    "--camera preset with depth"));
  }
  // With --depth, a colour frame without a depth frame would be tracked monocular, mixing scales
  // in one trajectory: such frames are left out (and counted).
  std::vector<const SequenceFrame*> frames;
  int skipped_no_depth = 0;
  for (const SequenceFrame& frame : sequence->frames) {
    if (args.max_frames > 0 && static_cast<int>(frames.size()) >= args.max_frames) break;
    if (args.depth && !frame.depth) {
      ++skipped_no_depth;
      continue;
    }
    frames.push_back(&frame);
  }
  if (frames.empty()) {
    return ReportError(context, absl::InvalidArgumentError("no frames to send"), args.sequence);
  }
  absl::StatusOr<cv::Size> size = ImageSize(frames.front()->image);
  if (!size.ok()) return ReportError(context, size.status());
  absl::StatusOr<v1::CreateSessionRequest> request =
      VoSessionRequest(args, *camera, size->width, size->height);
  if (!request.ok()) return ReportError(context, request.status());
  const fs::path out_dir = OutDir(args);
  std::error_code ec;
  fs::create_directories(out_dir / "frames", ec);
  if (ec) {
    return ReportError(context,
                       absl::PermissionDeniedError(absl::StrCat(
                           "cannot create '", (out_dir / "frames").string(), "': ", ec.message())));
  }

  std::unique_ptr<client::SlamClient> client = context.ConnectSlam();
  absl::StatusOr<v1::Session> session = client->CreateSession(*request);
  if (!session.ok()) return ReportError(context, session.status(), "CreateSession");
  const std::string session_id = session->session_id();

  RunState state;
  state.records.reserve(frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    VoFrameRecord record;
    record.index = static_cast<size_t>(frames[i] - sequence->frames.data());
    record.stamp = frames[i]->stamp;
    state.records.push_back(std::move(record));
    if (args.sample_every > 0 && i % static_cast<size_t>(args.sample_every) == 0) {
      state.sample_frames.insert(i);
    }
  }
  auto on_answer = [&state](size_t i, const v1::SlamUpdate& update) {
    std::lock_guard<std::mutex> lock(state.mutex);
    VoFrameRecord& record = state.records[i];
    record = RecordFromUpdate(update, record.index, record.stamp);
    if (record.rejected) return;
    const bool best = state.best_dynamic < 0 || record.dynamic > state.best_dynamic_count;
    if (best) {
      if (state.best_dynamic >= 0 && !state.sample_frames.count(state.best_dynamic)) {
        state.records[state.best_dynamic].features.clear();
        state.records[state.best_dynamic].features.shrink_to_fit();
      }
      state.best_dynamic = static_cast<long>(i);
      state.best_dynamic_count = record.dynamic;
    } else if (!state.sample_frames.count(i)) {
      record.features.clear();
      record.features.shrink_to_fit();
    }
  };
  ProgressBar progress(context.err, static_cast<int>(frames.size()), "frames", context.err_is_tty);
  const Clock::time_point start = Clock::now();
  size_t loaded = 0;  // the highest frame loaded so far, for progress (resends load again)
  absl::Status load_error;  // a frame that cannot be read ends the run: the sequence's fault
  auto load = [&](size_t i) -> absl::StatusOr<v1::ImageFrame> {
    const SequenceFrame& frame = *frames[i];
    v1::ImageFrame message;
    message.set_stamp(frame.stamp);
    absl::StatusOr<std::string> image = ReadFileBytes(frame.image);
    if (!image.ok()) return load_error = image.status();
    message.set_image(*std::move(image));
    if (args.depth) {
      absl::StatusOr<std::string> depth = ReadFileBytes(*frame.depth);
      if (!depth.ok()) return load_error = depth.status();
      message.set_depth(*std::move(depth));
    }
    message.set_want_features(true);
    if (i + 1 > loaded) {
      loaded = i + 1;
      progress.Update(static_cast<int>(loaded));
      if (!context.err_is_tty && loaded % 25 == 0) {
        context.err << fmt::format("vo: {}/{} frames sent\n", loaded, frames.size());
      }
    }
    return message;
  };
  auto on_event = [&](const std::string& message) {
    progress.Finish();  // a line of its own, not inside the bar
    context.err << "vo: " << message << "\n";
  };
  std::vector<double> stamps;
  for (const SequenceFrame* frame : frames) stamps.push_back(frame->stamp);
  ResumableFramesOptions stream_options;
  stream_options.window = args.window;
  stream_options.give_up_after = absl::Seconds(args.reconnect_seconds);
  ResumableFramesStats stream_stats;
  const absl::Status streamed = StreamFramesResumably(*client, session_id, stamps, load,
                                                      on_answer, on_event, stream_options,
                                                      &stream_stats);
  const double processing_s = std::chrono::duration<double>(Clock::now() - start).count();
  progress.Finish();
  if (!load_error.ok()) {
    (void)client->CloseSession(session_id);
    return ReportError(context, load_error, args.sequence);
  }
  if (!streamed.ok()) return ReportError(context, streamed, "stream of session " + session_id);

  // Every stream is finished: their reader threads are done with `state`.
  std::vector<VoFrameRecord>& records = state.records;
  size_t rejections = 0;
  for (const VoFrameRecord& r : records) {
    if (!r.rejected) continue;
    if (++rejections <= kRejectionsPrinted) {
      context.err << fmt::format("warning: frame {} (stamp {:.6f}, {}) rejected: code {}: {}\n",
                                 r.index, r.stamp,
                                 sequence->frames[r.index].image.filename().string(),
                                 r.rejection_code, r.rejection_message);
    }
  }
  if (rejections > kRejectionsPrinted) {
    context.err << fmt::format("warning: {} more frames rejected\n",
                               rejections - kRejectionsPrinted);
  }
  absl::StatusOr<v1::Session> closed = client->CloseSession(session_id);
  if (!closed.ok()) return ReportError(context, closed.status(), "CloseSession " + session_id);

  const std::vector<StampedPose3> poses = ProcessedPoses(records);
  if (absl::Status s = WriteTumPosesFile(out_dir / "trajectory.txt", poses); !s.ok()) {
    return ReportError(context, s);
  }

  nlohmann::json summary = {
      {"sequence", args.sequence},
      {"layout", SequenceLayoutName(sequence->layout)},
      {"session_id", session_id},
      {"detector", args.detector},
      {"preset", args.paper ? "paper" : "measured-best"},
      // What the server runs: the preset's filter unless --filter named one.
      {"filter", session->has_visual()
                     ? FilterName(session->visual().filter())
                     : (args.filter.empty() ? std::string("(preset)") : args.filter)},
      {"depth", args.depth},
      {"frames_in_sequence", sequence->frames.size()},
      {"frames_skipped_no_depth", skipped_no_depth},
      {"camera",
       {{"fx", camera->fx},
        {"fy", camera->fy},
        {"cx", camera->cx},
        {"cy", camera->cy},
        {"width", size->width},
        {"height", size->height},
        {"distortion", camera->distortion}}},
      {"processing_s", processing_s},
      {"fps", processing_s > 0 ? static_cast<double>(poses.size()) / processing_s : 0.0},
      {"window", args.window},
      {"max_outstanding", stream_stats.max_outstanding},
      {"stream_reconnects", stream_stats.reconnects},
      {"answers_lost", stream_stats.answers_lost},
      {"out_dir", out_dir.string()},
  };
  summary.update(FrameSummary(records));

  // Accuracy against the sequence's ground truth, with the existing `eval ate` code.
  std::optional<TrajectoryEvaluation> evaluation;
  std::vector<ResultWarning> result_warnings;
  const bool with_scale = !args.depth;  // monocular trajectories are scale-free
  if (sequence->groundtruth) {
    absl::StatusOr<std::vector<StampedPose3>> truth = ReadSequenceGroundTruth(*sequence);
    TrajectoryOptions options;  // `eval ate`'s defaults (0.02 s association window, delta 1)
    options.with_scale = with_scale;
    absl::StatusOr<TrajectoryEvaluation> evaluated =
        truth.ok() ? EvaluateTrajectory(poses, *truth, options)
                   : absl::StatusOr<TrajectoryEvaluation>(truth.status());
    if (evaluated.ok()) {
      evaluation = *std::move(evaluated);
      summary["groundtruth"] = sequence->groundtruth->string();
      summary.update(EvaluationSummary(*evaluation, with_scale));
      result_warnings = EvaluationWarnings(*evaluation, with_scale);
    } else {
      context.err << "warning: no ATE/RPE: " << evaluated.status().message() << "\n";
      summary["evaluation_error"] = std::string(evaluated.status().message());
    }
  }

  // When the numbers mean nothing (result_warnings.h): the session's own warnings (intrinsics that
  // do not fit the images), few tracked frames, no parallax, then the evaluation's.
  std::vector<ResultWarning> all_warnings = TrackingWarnings(records, /*monocular=*/!args.depth);
  all_warnings.insert(all_warnings.end(), result_warnings.begin(), result_warnings.end());
  for (const ResultWarning& warning : all_warnings) {
    context.err << "warning: " << warning.message << "\n";
  }
  summary.update(WarningsJson(all_warnings));

  // The picture's score carries the mark too: it is shown without the warnings.
  const std::string picture_mark = NotMeaningfulMark(all_warnings, "summary.json's warnings");
  std::string title = fmt::format("{}: {} frames", SequenceName(args.sequence), poses.size());
  if (evaluation) {
    std::string notes =
        with_scale ? fmt::format("Sim(3), scale {:.3f}", evaluation->alignment.scale) : "";
    if (!picture_mark.empty()) notes += (notes.empty() ? "" : ", ") + picture_mark;
    title += fmt::format(", ATE RMSE {:.4f} m{}", evaluation->ate.rmse,
                         notes.empty() ? "" : " (" + notes + ")");
  }
  // SVG for documents, PNG for a quick look (one layout, map_render.h).
  if (absl::Status s = WriteMapPictures(TrajectoryScene(poses, evaluation, title),
                                        out_dir / "trajectory.svg", out_dir / "trajectory.png",
                                        TrajectoryRenderOptions());
      !s.ok()) {
    return ReportError(context, s);
  }

  std::set<size_t> pictured = state.sample_frames;
  if (state.best_dynamic >= 0) pictured.insert(static_cast<size_t>(state.best_dynamic));
  nlohmann::json pictures = nlohmann::json::array();
  for (size_t i : pictured) {
    if (i >= records.size() || !records[i].answered || records[i].rejected) continue;
    const VoFrameRecord& r = records[i];
    const fs::path path = out_dir / "frames" / fmt::format("{:06d}.png", r.index);
    const std::string caption =
        fmt::format("frame {} {}: {} features, {} in boxes, {} dynamic, {} tracked, {} mapped{}",
                    r.index, r.state, r.total, r.potentially_dynamic, r.dynamic, r.tracked,
                    r.mapped, static_cast<long>(i) == state.best_dynamic ? " (most dynamic)" : "");
    if (absl::Status s = WriteFeatureFrame(sequence->frames[r.index].image, r, caption, path);
        !s.ok()) {
      context.err << "warning: " << s.message() << "\n";
      continue;
    }
    pictures.push_back(path.string());
  }
  summary["frame_pictures"] = pictures;
  if (state.best_dynamic >= 0) {
    summary["most_dynamic_frame"] = records[state.best_dynamic].index;
  }

  {
    std::ofstream out(out_dir / "summary.json");
    out << summary.dump(2) << "\n";
    if (!out) {
      return ReportError(context, absl::DataLossError(absl::StrCat(
                                      "cannot write ", (out_dir / "summary.json").string())));
    }
  }
  if (context.globals.json) {
    PrintJson(context.out, summary);
    return kExitOk;
  }
  context.out << fmt::format(
      "session {}: {} frames processed of {} sent ({} rejected, {} lost, {} keyframes) in {:.2f} "
      "s\n",
      session_id, summary["processed"].get<uint64_t>(), records.size(), rejections,
      summary["lost_frames"].get<uint64_t>(), summary["keyframes"].get<uint64_t>(), processing_s);
  context.out << fmt::format("server ms per frame: median {:.1f}, p90 {:.1f}\n",
                             summary["total_ms_median"].get<double>(),
                             summary["total_ms_p90"].get<double>());
  if (evaluation) context.out << AteLine(*evaluation, with_scale, all_warnings) << "\n";
  context.out << fmt::format(
      "wrote {}/trajectory.txt, trajectory.svg, trajectory.png, summary.json, {} frame "
      "pictures in frames/\n",
      out_dir.string(), pictures.size());
  return kExitOk;
}

}  // namespace waymark::cli
