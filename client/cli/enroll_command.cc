// `waymark enroll NAME DIR`: the views in DIR/<crossing>/<heading_deg>.<ext> (or
// DIR/<crossing>/<position>/<heading_deg>.<ext>) into a database over StreamEnroll
// (client/sessions/folder_enroll.h), with progress counting what the server stored.
// `waymark enroll NAME --video FILE --crossing C`: frames sampled from a video driven through the
// crossing (client/datasets/video_frames.h), enrolled the same way, tagged with their times.
// `waymark enroll NAME --manifest FILE`: the views a CSV file lists (client/datasets/
// enroll_manifest.h), for images whose names are not headings; `enroll NAME DIR --no-headings`:
// DIR/<crossing>/<any name>.jpg with no heading. A view with no heading answers its crossing only.
#include <fmt/format.h>

#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/common/stop_signals.h"
#include "client/datasets/enroll_manifest.h"
#include "client/datasets/image_folder.h"
#include "client/datasets/video_frames.h"
#include "client/sessions/folder_enroll.h"

namespace waymark::cli {
namespace {

struct EnrollArgs {
  std::string database;
  std::string dir;
  bool store_images = false;
  bool strict = false;
  bool replace = false;
  std::string manifest;      // --manifest FILE instead of DIR
  bool no_headings = false;  // DIR/<crossing>/<any name>.jpg, no heading
  // --video
  std::string video;
  std::string crossing;
  double heading_deg = 0;
  VideoSampling sampling;
};

// The views to enroll and, for a video, how they were sampled.
struct EnrollSource {
  std::vector<EnrollImage> images;
  std::optional<VideoSample> video;
};

int CountCrossings(const std::vector<EnrollImage>& images) {
  std::set<std::string> names;
  for (const EnrollImage& image : images) names.insert(image.crossing);
  return static_cast<int>(names.size());
}

std::string ProgressDetail(const EnrollTally& tally) {
  return fmt::format("{} stored, {} duplicates, {} invalid", tally.stored, tally.duplicates,
                     tally.invalid);
}

// "A/90" or "A/north-kerb/90" for people: the stored view's crossing, position and heading
// ("no heading" for a view stored without one).
std::string ViewPlace(const v1::EnrollViewResponse& answer) {
  const std::string heading = answer.heading_unknown()
                                  ? std::string("no heading")
                                  : fmt::format("{:g}", answer.heading_deg());
  if (answer.position().empty()) return fmt::format("{}/{}", answer.crossing(), heading);
  return fmt::format("{}/{}/{}", answer.crossing(), answer.position(), heading);
}

// A heading for JSON: null when the view has none.
nlohmann::json HeadingJson(const EnrollImage& image) {
  return HasHeading(image) ? nlohmann::json(image.heading_deg) : nlohmann::json(nullptr);
}

// The file a view came from: its image, or the video and the frame's time.
std::string ImageName(const EnrollImage& image) {
  if (image.encoded.empty()) return image.path.string();
  return fmt::format("{} at {}", image.path.string(), image.position);
}

// Skipped views worth a look, by file. A duplicate at its own place is a re-run (counted, not
// listed); one stored elsewhere is the same image filed twice.
void PrintSkipped(std::ostream& err, const FolderEnrollReport& report) {
  for (const SkippedImage& skipped : report.invalid) {
    err << fmt::format("skipped {}: {}\n", ImageName(skipped.image),
                       skipped.answer.error_message());
  }
  for (const SkippedImage& skipped : report.duplicates) {
    const bool same_heading = HasHeading(skipped.image)
                                  ? !skipped.answer.heading_unknown() &&
                                        skipped.answer.heading_deg() == skipped.image.heading_deg
                                  : skipped.answer.heading_unknown();
    if (skipped.answer.crossing() == skipped.image.crossing && same_heading &&
        skipped.answer.position() == skipped.image.position) {
      continue;
    }
    err << fmt::format(
        "skipped {}: the same image is already stored as view {} ({}); use --replace to move "
        "it here\n",
        ImageName(skipped.image), skipped.answer.view_id(), ViewPlace(skipped.answer));
  }
}

nlohmann::json VideoJson(const EnrollArgs& args, const VideoSample& video) {
  return {{"file", args.video},
          {"fps", video.fps},
          {"frames_read", video.frames_read},
          {"frames_declared", video.frames_declared},
          {"duration_s", video.duration_s()},
          {"every_s", video.every_s},
          {"sampled", video.sampled},
          {"kept", video.kept()},
          {"blurry", video.blurry},
          {"unchanged", video.unchanged},
          {"ended_early", video.ended_early}};
}

nlohmann::json ReportJson(const EnrollArgs& args, const EnrollSource& source, int crossings,
                          const FolderEnrollReport& report) {
  const EnrollTally& t = report.tally;
  nlohmann::json skipped = nlohmann::json::array();
  for (const SkippedImage& s : report.invalid) {
    skipped.push_back({{"path", s.image.path.string()},
                       {"crossing", s.image.crossing},
                       {"position", s.image.position},
                       {"heading_deg", HeadingJson(s.image)},
                       {"reason", s.answer.error_message()}});
  }
  nlohmann::json duplicates = nlohmann::json::array();
  for (const SkippedImage& s : report.duplicates) {
    duplicates.push_back({{"path", s.image.path.string()},
                          {"position", s.image.position},
                          {"stored_view_id", s.answer.view_id()},
                          {"stored_crossing", s.answer.crossing()},
                          {"stored_position", s.answer.position()},
                          {"stored_heading_deg", s.answer.heading_unknown()
                                                     ? nlohmann::json(nullptr)
                                                     : nlohmann::json(s.answer.heading_deg())}});
  }
  nlohmann::json json = {{"database", args.database},
                         {"crossings", crossings},
                         {"views_total", t.total},
                         {"views_sent", t.sent},
                         {"views", t.stored},
                         {"duplicates", t.duplicates},
                         {"invalid", t.invalid},
                         {"remaining", t.remaining()},
                         {"views_replaced", t.replaced},
                         {"crossings_created", t.crossings_created},
                         {"clusters_created", t.clusters_created},
                         {"keypoints", t.keypoints},
                         {"skipped", std::move(skipped)},
                         {"duplicate_views", std::move(duplicates)},
                         {"complete", report.status.ok() && !report.stopped}};
  if (source.video.has_value()) json["video"] = VideoJson(args, *source.video);
  if (!report.status.ok()) {
    json["error"] = {{"code", absl::StatusCodeToString(report.status.code())},
                     {"message", std::string(report.status.message())}};
  }
  return json;
}

// "drive.mp4: 40 frames sampled every 0.5 s over 20.0 s: 36 kept, 3 blurry, 1 unchanged".
std::string DescribeSampling(const EnrollArgs& args, const VideoSample& video) {
  return fmt::format("{}: {} frames sampled every {:g} s over {:.1f} s: {} kept, {} blurry, {} "
                     "unchanged",
                     args.video, video.sampled, video.every_s, video.duration_s(),
                     video.kept(), video.blurry, video.unchanged);
}

// The frames of args.video as views of args.crossing, tagged with their times. Sampling reads the
// whole video before anything is sent: a video that cannot be read enrolls nothing.
absl::StatusOr<EnrollSource> SampleVideoViews(CommandContext& context, const EnrollArgs& args) {
  std::optional<ProgressBar> progress;  // made at the first frame, when the count is known
  absl::StatusOr<VideoSample> video =
      SampleVideo(args.video, args.sampling, [&](const VideoSample& sample) {
        if (!progress.has_value()) {
          progress.emplace(context.err, static_cast<int>(sample.frames_declared), "frames",
                           context.err_is_tty);
        }
        progress->Update(static_cast<int>(sample.frames_read),
                         fmt::format("{} kept, {} blurry, {} unchanged", sample.kept(),
                                     sample.blurry, sample.unchanged));
      });
  if (progress.has_value()) progress->Finish();
  if (!video.ok()) {
    return absl::Status(video.status().code(),
                        absl::StrCat(video.status().message(), "; nothing was enrolled"));
  }
  if (video->ended_early) {
    context.err << fmt::format(
        "warning: {} ended after {} of the {} frames it declares (truncated or corrupt?); "
        "enrolling the {} frames sampled before that\n",
        args.video, video->frames_read, video->frames_declared, video->kept());
  }
  if (video->frames.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        DescribeSampling(args, *video), ": no frame to enroll, nothing was enrolled (lower "
        "--min-sharpness or --min-change, 0 turns a check off)"));
  }
  EnrollSource source;
  for (SampledFrame& frame : video->frames) {
    source.images.push_back({args.crossing, args.heading_deg, args.video,
                             FramePosition(frame.t_s), std::move(frame.jpeg)});
  }
  source.video = *std::move(video);
  source.video->frames.clear();  // the bytes moved into the views
  return source;
}

absl::StatusOr<EnrollSource> ReadSource(CommandContext& context, const EnrollArgs& args) {
  const int sources = !args.dir.empty() + !args.video.empty() + !args.manifest.empty();
  if (sources != 1) {
    return absl::InvalidArgumentError(
        "give one of DIR, --manifest FILE or --video FILE (with --crossing NAME)");
  }
  if (!args.video.empty()) return SampleVideoViews(context, args);
  absl::StatusOr<std::vector<EnrollImage>> images =
      !args.manifest.empty() ? ReadEnrollManifest(args.manifest)
      : args.no_headings     ? ScanUnheadedFolder(args.dir)
                             : ScanEnrollFolder(args.dir);
  if (!images.ok() && args.manifest.empty() && !args.no_headings &&
      images.status().code() == absl::StatusCode::kInvalidArgument) {
    // File names that are not headings: say how to enroll them anyway.
    return absl::InvalidArgumentError(absl::StrCat(
        images.status().message(),
        "\nimages whose names are not headings (p0_i0.jpg): list them with their crossing and "
        "heading in a CSV file and run `waymark enroll NAME --manifest FILE` (",
        kManifestLayout, "), or enroll DIR/<crossing>/<any name>.jpg with no heading with "
        "--no-headings"));
  }
  if (!images.ok()) return images.status();
  return EnrollSource{*std::move(images), std::nullopt};
}

int RunEnroll(CommandContext& context, const EnrollArgs& args) {
  absl::StatusOr<EnrollSource> source = ReadSource(context, args);
  if (!source.ok()) return ReportError(context, source.status());
  const std::vector<EnrollImage>& images = source->images;
  const int crossings = CountCrossings(images);

  std::unique_ptr<client::CrossingClient> client = context.Connect();
  ProgressBar progress(context.err, static_cast<int>(images.size()), "views",
                       context.err_is_tty);
  FolderEnrollOptions options;
  options.database = args.database;
  options.store_images = args.store_images;
  options.strict = args.strict;
  options.replace = args.replace;
  StopSignals signals;
  const FolderEnrollReport report =
      EnrollFolder(*client, images, options, signals.stop_requested(),
                   [&](const EnrollTally& tally) {
                     progress.Update(tally.answered(), ProgressDetail(tally));
                   });
  progress.Finish();
  PrintSkipped(context.err, report);

  const EnrollTally& t = report.tally;
  const bool complete = report.status.ok() && !report.stopped;
  if (context.globals.json) PrintJson(context.out, ReportJson(args, *source, crossings, report));
  if (complete) {
    if (!context.globals.json) {
      if (source->video.has_value()) {
        context.out << DescribeSampling(args, *source->video) << "\n";
      }
      context.out << fmt::format(
          "{} views of {} crossings into {}: {}; {} crossings created, {} clusters created, {} "
          "keypoints\n",
          t.total, crossings, args.database, DescribeOutcomes(t), t.crossings_created,
          t.clusters_created, t.keypoints);
    }
    return kExitOk;
  }
  // Stopped or failed: what was done, and that a re-run picks up where this one ended.
  if (!report.status.ok()) ReportError(context, report.status);
  context.err << fmt::format(
      "{} after {} of {} views: {}, {} not enrolled; each view is stored completely or not at "
      "all, and running the same command again enrolls the rest (stored views are skipped as "
      "duplicates)\n",
      report.status.ok() ? "interrupted" : "stopped", t.answered(), t.total, DescribeOutcomes(t),
      t.remaining());
  return report.status.ok() ? kExitInterrupted : kExitFailure;
}

}  // namespace

void AddEnrollCommand(CLI::App& app, CommandRegistry& registry) {
  auto args = std::make_shared<EnrollArgs>();
  CLI::App* enroll = app.add_subcommand(
      "enroll",
      "Enroll DIR/<crossing>/<heading_deg>.(jpg|jpeg|png) into a database, creating crossings as "
      "needed; views are sent in crossing, then heading order. A heading is the file name: degrees "
      "in [0, 360) with at most 3 digits before the point (030.jpg, 30.5.png). A crossing captured "
      "from several positions holds one folder per position instead, "
      "DIR/<crossing>/<position>/<heading_deg>.jpg; the folder name is the view's position tag "
      "(north-kerb, p2). Or, with --video FILE --crossing NAME, enroll frames sampled from a video "
      "driven through the crossing, tagged with their times (t=12.5s). Images already stored "
      "(same bytes) are skipped, so an interrupted or repeated enroll is safe to re-run. Ctrl-C "
      "stops after the views in flight and says what was stored");
  enroll->add_option("NAME", args->database, "Database name")->required();
  CLI::Option* dir = enroll->add_option("DIR", args->dir, "Folder of crossing folders");
  CLI::Option* manifest =
      enroll->add_option("--manifest", args->manifest,
                         "Instead of DIR: a CSV file listing the views, one per line: "
                         "file,crossing,heading[,position] (file relative to the CSV's folder; "
                         "heading in degrees in [0, 360), or empty or `unknown` for a view whose "
                         "heading is not known: it answers its crossing and no heading). For "
                         "images whose names are not headings (p0_i0.JPG)");
  dir->excludes(manifest);
  CLI::Option* no_headings = enroll->add_flag(
      "--no-headings", args->no_headings,
      "DIR/<crossing>/<any name>.jpg: the file names are not headings, every view is stored with "
      "no heading (recognition then answers the crossing and no heading)");
  no_headings->needs(dir);
  enroll->add_flag("--store-images", args->store_images,
                   "Keep the encoded images in the database (for rebuilds and inspection)");
  enroll->add_flag("--strict", args->strict,
                   "Stop at the first invalid view (default: skip it with a warning and go on)");
  enroll->add_flag("--replace", args->replace,
                   "Replace the stored views of the same crossing, position and heading (and the "
                   "same image stored elsewhere) instead of skipping the file; re-clusters the "
                   "database per replaced view");

  const std::string video_group = "Video";
  CLI::Option* video =
      enroll
          ->add_option("--video", args->video,
                       "Instead of DIR: a video file (anything OpenCV's FFmpeg backend decodes, "
                       "e.g. .mp4, .avi) of a drive through one crossing. The whole video is "
                       "sampled before anything is sent: one that cannot be read enrolls nothing")
          ->group(video_group);
  dir->excludes(video);
  manifest->excludes(video);
  CLI::Option* crossing =
      enroll->add_option("--crossing", args->crossing, "The crossing the video's frames show")
          ->group(video_group);
  video->needs(crossing);
  crossing->needs(video);
  enroll
      ->add_option("--every-s", args->sampling.every_s,
                   "One frame per this many seconds of video, from the first frame")
      ->check(CLI::Range(0.01, 3600.0))
      ->capture_default_str()
      ->needs(video)
      ->group(video_group);
  enroll
      ->add_option("--max-frames", args->sampling.max_frames,
                   "Keep at most N frames; a longer video is sampled with a wider step, so the "
                   "N frames span all of it (0 = no limit)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str()
      ->needs(video)
      ->group(video_group);
  enroll
      ->add_option("--heading", args->heading_deg,
                   "Heading of every frame, degrees in [0, 360): a video has no compass, so the "
                   "default 0 only says \"the direction of travel\"; give the compass heading of "
                   "the drive when it is known")
      ->check(CLI::Range(0.0, 359.999999))
      ->capture_default_str()
      ->needs(video)
      ->group(video_group);
  enroll
      ->add_option("--min-sharpness", args->sampling.min_sharpness,
                   "Skip frames whose variance of the Laplacian (at 320 px wide) is below this: "
                   "motion blur leaves SIFT too few keypoints (0 = keep all)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str()
      ->needs(video)
      ->group(video_group);
  enroll
      ->add_option("--min-change", args->sampling.min_change,
                   "Skip frames that differ from the last kept one by less than this mean grey "
                   "level (at 64x48): the robot was standing still (0 = keep all)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str()
      ->needs(video)
      ->group(video_group);
  registry.Add(enroll, [args](CommandContext& c) { return RunEnroll(c, *args); });
}

}  // namespace waymark::cli
