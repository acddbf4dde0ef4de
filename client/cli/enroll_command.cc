// `waymark enroll NAME DIR`: the views in DIR/<crossing>/<heading_deg>.<ext> into a database over
// StreamEnroll (client/sessions/folder_enroll.h), with progress counting what the server stored.
#include <fmt/format.h>

#include <memory>
#include <set>
#include <string>

#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/common/stop_signals.h"
#include "client/datasets/image_folder.h"
#include "client/sessions/folder_enroll.h"

namespace waymark::cli {
namespace {

struct EnrollArgs {
  std::string database;
  std::string dir;
  bool store_images = false;
  bool strict = false;
  bool replace = false;
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

// "A/090" for people: the stored view's crossing and heading.
std::string ViewPlace(const v1::EnrollViewResponse& answer) {
  return fmt::format("{}/{:g}", answer.crossing(), answer.heading_deg());
}

// Skipped views worth a look, by file. A duplicate at its own place is a re-run (counted, not
// listed); one stored elsewhere is the same image filed twice.
void PrintSkipped(std::ostream& err, const FolderEnrollReport& report) {
  for (const SkippedImage& skipped : report.invalid) {
    err << fmt::format("skipped {}: {}\n", skipped.image.path.string(),
                       skipped.answer.error_message());
  }
  for (const SkippedImage& skipped : report.duplicates) {
    if (skipped.answer.crossing() == skipped.image.crossing &&
        skipped.answer.heading_deg() == skipped.image.heading_deg) {
      continue;
    }
    err << fmt::format(
        "skipped {}: the same image is already stored as view {} ({}); use --replace to move "
        "it here\n",
        skipped.image.path.string(), skipped.answer.view_id(), ViewPlace(skipped.answer));
  }
}

nlohmann::json ReportJson(const EnrollArgs& args, int crossings, const FolderEnrollReport& report) {
  const EnrollTally& t = report.tally;
  nlohmann::json skipped = nlohmann::json::array();
  for (const SkippedImage& s : report.invalid) {
    skipped.push_back({{"path", s.image.path.string()},
                       {"crossing", s.image.crossing},
                       {"heading_deg", s.image.heading_deg},
                       {"reason", s.answer.error_message()}});
  }
  nlohmann::json duplicates = nlohmann::json::array();
  for (const SkippedImage& s : report.duplicates) {
    duplicates.push_back({{"path", s.image.path.string()},
                          {"stored_view_id", s.answer.view_id()},
                          {"stored_crossing", s.answer.crossing()},
                          {"stored_heading_deg", s.answer.heading_deg()}});
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
  if (!report.status.ok()) {
    json["error"] = {{"code", absl::StatusCodeToString(report.status.code())},
                     {"message", std::string(report.status.message())}};
  }
  return json;
}

int RunEnroll(CommandContext& context, const EnrollArgs& args) {
  auto images = ScanEnrollFolder(args.dir);
  if (!images.ok()) return ReportError(context, images.status());
  const int crossings = CountCrossings(*images);

  std::unique_ptr<client::CrossingClient> client = context.Connect();
  ProgressBar progress(context.err, static_cast<int>(images->size()), "views",
                       context.err_is_tty);
  FolderEnrollOptions options;
  options.database = args.database;
  options.store_images = args.store_images;
  options.strict = args.strict;
  options.replace = args.replace;
  StopSignals signals;
  const FolderEnrollReport report =
      EnrollFolder(*client, *images, options, signals.stop_requested(),
                   [&](const EnrollTally& tally) {
                     progress.Update(tally.answered(), ProgressDetail(tally));
                   });
  progress.Finish();
  PrintSkipped(context.err, report);

  const EnrollTally& t = report.tally;
  const bool complete = report.status.ok() && !report.stopped;
  if (context.globals.json) PrintJson(context.out, ReportJson(args, crossings, report));
  if (complete) {
    if (!context.globals.json) {
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
      "in [0, 360) with at most 3 digits before the point (030.jpg, 30.5.png). Images already "
      "stored (same bytes) are skipped, so an interrupted or repeated enroll is safe to re-run. "
      "Ctrl-C stops after the views in flight and says what was stored");
  enroll->add_option("NAME", args->database, "Database name")->required();
  enroll->add_option("DIR", args->dir, "Folder of crossing folders")->required();
  enroll->add_flag("--store-images", args->store_images,
                   "Keep the encoded images in the database (for rebuilds and inspection)");
  enroll->add_flag("--strict", args->strict,
                   "Stop at the first invalid view (default: skip it with a warning and go on)");
  enroll->add_flag("--replace", args->replace,
                   "Replace the stored views of the same crossing and heading (and the same image "
                   "stored elsewhere) instead of skipping the file; re-clusters the database per "
                   "replaced view");
  registry.Add(enroll, [args](CommandContext& c) { return RunEnroll(c, *args); });
}

}  // namespace waymark::cli
