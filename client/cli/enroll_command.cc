// `waymark enroll NAME DIR`: bulk import of DIR/<crossing>/<heading_deg>.<ext> over BulkEnroll.
#include <fmt/format.h>

#include <memory>
#include <set>
#include <string>

#include "client/cli/command.h"
#include "client/datasets/image_folder.h"
#include "client/common/output.h"
#include "client/common/progress_bar.h"
#include "client/common/proto_json.h"
#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

struct EnrollArgs {
  std::string database;
  std::string dir;
  bool store_images = false;
  bool strict = false;
};

int CountCrossings(const std::vector<EnrollImage>& images) {
  std::set<std::string> names;
  for (const EnrollImage& image : images) names.insert(image.crossing);
  return static_cast<int>(names.size());
}

int RunEnroll(CommandContext& context, const EnrollArgs& args) {
  auto images = ScanEnrollFolder(args.dir);
  if (!images.ok()) return ReportError(context, images.status());
  const int total = static_cast<int>(images->size());
  const int crossings = CountCrossings(*images);

  std::unique_ptr<client::CrossingClient> client = context.Connect();
  std::unique_ptr<client::BulkEnrollWriter> writer = client->BulkEnroll();
  ProgressBar progress(context.err, total, "views", context.err_is_tty);
  int sent = 0;
  for (const EnrollImage& image : *images) {
    auto bytes = ReadFileBytes(image.path);
    if (!bytes.ok()) {
      // Views already sent stay enrolled; say so, so that a rerun is not a surprise.
      writer->Cancel();
      progress.Finish();
      return ReportError(context, bytes.status(),
                         fmt::format("stopped after sending {} of {} views", sent, total));
    }
    v1::EnrollViewRequest request;
    request.set_database(args.database);
    request.set_crossing(image.crossing);
    request.set_heading_deg(image.heading_deg);
    request.mutable_image()->set_data(*std::move(bytes));
    request.set_create_crossing(true);
    request.set_store_image(args.store_images);
    request.set_skip_invalid(!args.strict);
    if (!writer->Write(request)) break;  // the server ended the stream; Finish() says why
    progress.Update(++sent);
  }
  auto result = writer->Finish();
  progress.Finish();
  if (!result.ok()) {
    // Writes are buffered, so the view the server rejected is not necessarily the last one sent.
    return ReportError(context, result.status(),
                       fmt::format("enrollment stopped after sending {} of {} views; the views "
                                   "the server accepted before the error stay enrolled",
                                   sent, total));
  }

  if (context.globals.json) {
    nlohmann::json json = ProtoToJson(*result);
    json["database"] = args.database;
    json["crossings"] = crossings;
    json["views_sent"] = sent;
    PrintJson(context.out, json);
  } else {
    context.out << fmt::format(
        "enrolled {} views of {} crossings into {}: {} crossings created, {} clusters created, "
        "{} keypoints\n",
        result->views(), crossings, args.database, result->crossings_created(),
        result->clusters_created(), result->keypoints());
  }
  // Skipped views are worth a look (a blank wall, a corrupt file), but the rest is enrolled.
  for (const v1::SkippedView& skipped : result->skipped()) {
    context.err << fmt::format("skipped {}/{:g}: {}\n", skipped.crossing(), skipped.heading_deg(),
                               skipped.reason());
  }
  return kExitOk;
}

}  // namespace

void AddEnrollCommand(CLI::App& app, CommandRegistry& registry) {
  auto args = std::make_shared<EnrollArgs>();
  CLI::App* enroll = app.add_subcommand(
      "enroll",
      "Enroll DIR/<crossing>/<heading_deg>.(jpg|jpeg|png) into a database, creating crossings as "
      "needed; views are sent in crossing, then heading order");
  enroll->add_option("NAME", args->database, "Database name")->required();
  enroll->add_option("DIR", args->dir, "Folder of crossing folders")->required();
  enroll->add_flag("--store-images", args->store_images,
                   "Keep the encoded images in the database (for rebuilds and inspection)");
  enroll->add_flag("--strict", args->strict,
                   "Stop at the first invalid view (default: skip it with a warning and go on)");
  registry.Add(enroll, [args](CommandContext& c) { return RunEnroll(c, *args); });
}

}  // namespace waymark::cli
