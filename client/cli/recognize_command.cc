// `waymark recognize NAME IMAGE...` (one RecognizeCrossing per file; a folder stands for its
// images) and
// `waymark recognize NAME --camera SOURCE` (camera frames through StreamRecognize).
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/cli/command.h"
#include "client/datasets/image_folder.h"
#include "client/devices/camera_source.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"
#include "client/common/read_file.h"
#include "client/cli/recognition_flags.h"
#include "client/cli/recognition_output.h"

namespace waymark::cli {
namespace {

struct RecognizeArgs {
  std::string database;
  std::vector<std::string> images;
  std::string camera;
  int max_frames = 0;
  bool until_recognized = false;
  bool verbose = false;
  client::CameraSourceOptions camera_options;
  RecognitionFlags recognition;
};

v1::RecognizeRequest MakeRequest(const RecognizeArgs& args, std::string image_bytes, double stamp) {
  v1::RecognizeRequest request;
  request.set_database(args.database);
  request.mutable_image()->set_data(std::move(image_bytes));
  request.mutable_image()->set_stamp(stamp);
  *request.mutable_params() = args.recognition.ToParams();
  return request;
}

double WallSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

nlohmann::json ErrorJson(const absl::Status& status) {
  return {{"code", absl::StatusCodeToString(status.code())},
          {"message", std::string(status.message())}};
}

void PrintVerbose(std::ostream& out, const v1::RecognizeResponse& response) {
  out << "  " << RecognitionDetails(response) << "\n";
  PrintCandidateTable(out, response);
}

// The IMAGE arguments with every folder replaced by its images, sorted by name (ListFolderImages
// says why a folder has none).
absl::StatusOr<std::vector<std::string>> ExpandFolders(const std::vector<std::string>& arguments) {
  std::vector<std::string> images;
  for (const std::string& argument : arguments) {
    std::error_code ec;
    if (!std::filesystem::is_directory(argument, ec)) {
      images.push_back(argument);
      continue;
    }
    absl::StatusOr<std::vector<std::filesystem::path>> found = ListFolderImages(argument);
    if (!found.ok()) return found.status();
    for (const std::filesystem::path& path : *found) images.push_back(path.string());
  }
  return images;
}

int RunImages(CommandContext& context, const RecognizeArgs& args) {
  absl::StatusOr<std::vector<std::string>> images = ExpandFolders(args.images);
  if (!images.ok()) return ReportError(context, images.status());
  std::unique_ptr<client::CrossingClient> client = context.Connect();
  nlohmann::json results = nlohmann::json::array();
  int failures = 0;
  for (const std::string& image : *images) {
    auto bytes = ReadFileBytes(image);
    const auto start = std::chrono::steady_clock::now();
    auto response = bytes.ok() ? client->RecognizeCrossing(MakeRequest(args, *std::move(bytes), 0))
                               : absl::StatusOr<v1::RecognizeResponse>(bytes.status());
    const double latency_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!response.ok()) {
      // One bad file should not hide the results of the others; the exit code still reports it.
      ++failures;
      ReportError(context, response.status(), image);
      results.push_back({{"image", image}, {"error", ErrorJson(response.status())}});
      continue;
    }
    nlohmann::json json = ProtoToJson(*response);
    json["image"] = image;
    json["latency_ms"] = latency_ms;
    results.push_back(std::move(json));
    if (!context.globals.json) {
      context.out << fmt::format("{}: {} [{:.1f} ms round trip]\n", image,
                                 RecognitionSummary(*response), latency_ms);
      if (args.verbose) PrintVerbose(context.out, *response);
    }
  }
  if (context.globals.json) {
    PrintJson(context.out, {{"database", args.database}, {"results", std::move(results)}});
  }
  return failures == 0 ? kExitOk : kExitFailure;
}

int RunCamera(CommandContext& context, const RecognizeArgs& args) {
  auto camera = client::CameraSource::Open(args.camera, args.camera_options);
  if (!camera.ok()) return ReportError(context, camera.status());
  std::unique_ptr<client::CrossingClient> client = context.Connect();
  std::unique_ptr<client::RecognizeStream> stream = client->StreamRecognize();

  nlohmann::json frames = nlohmann::json::array();
  std::optional<int64_t> first_recognized;
  std::string end_reason = "stopped";
  // Lock-step (send a frame, read its result): the robot never queues more than one frame, so
  // each result is about the freshest view the server could take.
  for (int sent = 0; args.max_frames == 0 || sent < args.max_frames; ++sent) {
    absl::StatusOr<std::string> jpeg = (*camera)->Next();
    if (absl::IsOutOfRange(jpeg.status())) {
      end_reason = std::string(jpeg.status().message());
      break;
    }
    if (!jpeg.ok()) {
      stream->Cancel();
      return ReportError(context, jpeg.status(), args.camera);
    }
    v1::RecognizeResponse response;
    if (!stream->Send(MakeRequest(args, *std::move(jpeg), WallSeconds())) ||
        !stream->Read(&response)) {
      break;  // the server ended the stream; Finish() below reports why
    }
    if (!context.globals.json) {
      context.out << fmt::format("frame {}: {} [{:.1f} ms]\n", response.frame_index(),
                                 RecognitionSummary(response), response.timings().total_ms());
      if (args.verbose) PrintVerbose(context.out, response);
    }
    frames.push_back(ProtoToJson(response));
    if (response.recognized() && !first_recognized.has_value()) {
      first_recognized = response.frame_index();
    }
    if (args.until_recognized && response.recognized()) {
      end_reason = "recognized";
      break;
    }
    if (args.max_frames != 0 && sent + 1 == args.max_frames) end_reason = "max frames reached";
  }
  stream->WritesDone();
  for (v1::RecognizeResponse rest; stream->Read(&rest);) {
  }
  if (absl::Status status = stream->Finish(); !status.ok()) {
    return ReportError(context, status, fmt::format("after {} frames", frames.size()));
  }

  if (context.globals.json) {
    PrintJson(context.out, {{"database", args.database},
                            {"source", args.camera},
                            {"frames", std::move(frames)},
                            {"recognized", first_recognized.has_value()},
                            {"first_recognized_frame", first_recognized.has_value()
                                                           ? nlohmann::json(*first_recognized)
                                                           : nlohmann::json(nullptr)},
                            {"end", end_reason}});
  } else {
    context.out << fmt::format("{} frames, {} ({})\n", frames.size(),
                               first_recognized.has_value()
                                   ? fmt::format("first recognized at frame {}", *first_recognized)
                                   : std::string("none recognized"),
                               end_reason);
  }
  return kExitOk;
}

int RunRecognize(CommandContext& context, const RecognizeArgs& args) {
  if (args.images.empty() == args.camera.empty()) {
    return ReportError(context,
                       absl::InvalidArgumentError("give either IMAGE files or --camera SOURCE"));
  }
  return args.camera.empty() ? RunImages(context, args) : RunCamera(context, args);
}

}  // namespace

void AddRecognizeCommand(CLI::App& app, CommandRegistry& registry) {
  auto args = std::make_shared<RecognizeArgs>();
  CLI::App* recognize = app.add_subcommand(
      "recognize", "Recognize the crossing and heading in image files or camera frames");
  recognize->add_option("NAME", args->database, "Database name")->required();
  CLI::Option* images = recognize->add_option(
      "IMAGE", args->images,
      "Image files (JPEG or PNG), or folders: each stands for the images directly in it, sorted "
      "by name");
  CLI::Option* camera = recognize->add_option(
      "--camera", args->camera,
      "Stream frames instead: a device index (0), a video file, a stream URL, or an image "
      "sequence pattern (frames/%04d.png)");
  images->excludes(camera);
  recognize->add_option("--max-frames", args->max_frames, "Stop after N frames (0 = all)")
      ->check(CLI::NonNegativeNumber)
      ->needs(camera);
  recognize
      ->add_flag("--until-recognized", args->until_recognized, "Stop at the first recognized frame")
      ->needs(camera);
  const std::string camera_group = "Camera frames";
  recognize->add_option("--frame-width", args->camera_options.width, "Resize frames to this width")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str()
      ->group(camera_group);
  recognize->add_option("--frame-height", args->camera_options.height, "and this height")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str()
      ->group(camera_group);
  recognize->add_option("--jpeg-quality", args->camera_options.jpeg_quality, "JPEG quality")
      ->check(CLI::Range(0, 100))
      ->capture_default_str()
      ->group(camera_group);
  recognize->add_flag("-v,--verbose", args->verbose,
                      "Print timings and the candidate table (the paper's Table 1)");
  args->recognition.Register(recognize);
  registry.Add(recognize, [args](CommandContext& c) { return RunRecognize(c, *args); });
}

}  // namespace waymark::cli
