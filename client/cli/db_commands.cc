// `waymark db create|list|stats|delete`: crossing database management.
//
// `db create` without options makes the best measured database (issue 34, docs/results.md):
// retrieval mode, RootSIFT descriptors, images fitted keeping their aspect ratio, the global stage.
// `--mode paper` makes the paper's exact configuration (plain SIFT, images squeezed to the working
// size); `--mode verified` the verified mode on the paper's features, which its rejection rule was
// calibrated on. --root-sift / --keep-aspect (and their --no- forms) override the mode's choice.
#include <fmt/format.h>

#include <memory>
#include <string>

#include "absl/time/time.h"
#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"
#include "client/cli/recognition_flags.h"

namespace waymark::cli {
namespace {

struct CreateArgs {
  std::string name;
  int work_width = 0;
  int work_height = 0;
  int hue_bins = 0;
  int cluster_threshold = 0;
  int max_keypoints = 0;
  std::string mode;
  bool keep_aspect = false;
  bool root_sift = false;
  bool global_descriptor = false;
  CLI::Option* keep_aspect_option = nullptr;
  CLI::Option* root_sift_option = nullptr;
  CLI::Option* global_descriptor_option = nullptr;
  CLI::Option* work_width_option = nullptr;
  CLI::Option* work_height_option = nullptr;
  CLI::Option* hue_bins_option = nullptr;
  CLI::Option* cluster_threshold_option = nullptr;
  CLI::Option* max_keypoints_option = nullptr;
  CLI::Option* mode_option = nullptr;
};

// The mode `db create` gives a database when --mode is not given: the best measured.
constexpr v1::RecognitionMode kDefaultCreateMode = v1::RECOGNITION_MODE_RETRIEVAL;

// The mode and features are always sent (the best measured configuration unless the command line
// says otherwise); the other options only when given, so the server's defaults apply to them.
v1::CreateDatabaseRequest MakeCreateRequest(const CreateArgs& args) {
  v1::CreateDatabaseRequest request;
  request.set_name(args.name);
  v1::DatabaseParams* params = request.mutable_params();
  if (args.work_width_option->count() > 0) params->set_work_width(args.work_width);
  if (args.work_height_option->count() > 0) params->set_work_height(args.work_height);
  if (args.hue_bins_option->count() > 0) params->set_hue_bins(args.hue_bins);
  if (args.cluster_threshold_option->count() > 0) {
    params->set_cluster_threshold(args.cluster_threshold);
  }
  if (args.max_keypoints_option->count() > 0) params->set_max_keypoints(args.max_keypoints);
  const v1::RecognitionMode mode =
      args.mode_option->count() > 0 ? ModeFromName(args.mode) : kDefaultCreateMode;
  params->mutable_recognition()->set_mode(mode);
  // RootSIFT and kept aspect are the retrieval mode's measured best; the paper's mode keeps the
  // paper's features exactly, the verified mode the features its rule was calibrated on.
  const bool retrieval = mode == v1::RECOGNITION_MODE_RETRIEVAL;
  params->set_root_sift(args.root_sift_option->count() > 0 ? args.root_sift : retrieval);
  params->set_keep_aspect(args.keep_aspect_option->count() > 0 ? args.keep_aspect : retrieval);
  if (args.global_descriptor_option->count() > 0) {
    params->set_global_descriptor(args.global_descriptor);
  }
  return request;
}

std::string FormatTime(double unix_seconds) {
  return absl::FormatTime("%Y-%m-%d %H:%M:%S", absl::FromUnixSeconds(unix_seconds),
                          absl::LocalTimeZone());
}

std::string Resolution(const v1::DatabaseParams& params) {
  return fmt::format("{}x{}", params.work_width(), params.work_height());
}

void PrintDatabase(std::ostream& out, const v1::CrossingDatabase& db) {
  const v1::DatabaseParams& p = db.params();
  out << fmt::format("database     {} (id {}, created {})\n", db.name(), db.id(),
                     FormatTime(db.created_at()));
  out << fmt::format("contents     {} crossings, {} views, {} clusters\n", db.crossings(),
                     db.views(), db.clusters());
  out << fmt::format(
      "parameters   {} working resolution, {} hue bins, cluster threshold {}, max keypoints {}, "
      "{} mode\n",
      Resolution(p), p.hue_bins(), p.cluster_threshold(),
      p.max_keypoints() == 0 ? std::string("unlimited") : std::to_string(p.max_keypoints()),
      ModeName(p.recognition().mode()));
  out << fmt::format("features     {}, {}{}\n", p.root_sift() ? "RootSIFT (root_sift)" : "SIFT",
                     p.keep_aspect() ? "images fitted keeping their aspect (keep_aspect)"
                                     : "images resized to the working size (the paper's)",
                     p.global_descriptor() ? ", global descriptor (dense RootSIFT VLAD)" : "");
}

int RunCreate(CommandContext& context, const CreateArgs& args) {
  auto db = context.Connect()->CreateDatabase(MakeCreateRequest(args));
  if (!db.ok()) return ReportError(context, db.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*db));
  } else {
    context.out << "created database " << db->name() << "\n";
    PrintDatabase(context.out, *db);
  }
  return kExitOk;
}

int RunList(CommandContext& context) {
  auto list = context.Connect()->ListDatabases();
  if (!list.ok()) return ReportError(context, list.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*list));
    return kExitOk;
  }
  if (list->databases().empty()) {
    context.out << "no databases (create one with: waymark db create NAME)\n";
    return kExitOk;
  }
  Table table({{"name"},
               {"crossings", true},
               {"views", true},
               {"clusters", true},
               {"resolution"},
               {"mode"},
               {"created"}});
  for (const v1::CrossingDatabase& db : list->databases()) {
    table.AddRow({db.name(), std::to_string(db.crossings()), std::to_string(db.views()),
                  std::to_string(db.clusters()), Resolution(db.params()),
                  ModeName(db.params().recognition().mode()), FormatTime(db.created_at())});
  }
  table.Print(context.out);
  return kExitOk;
}

// The global stage's vocabulary schedule (server/service/crossing/global_stage.h): learnt at 16 views, then
// at every doubling up to 512.
constexpr int kFirstVocabularyViews = 16;
constexpr int kLastVocabularyViews = 512;

// "global       on, vocabulary learnt from 64 views (the next at 128 views), 70 of 70 views coded"
std::string GlobalStageLine(const v1::DatabaseStats& stats) {
  const int views = stats.database().views();
  if (!stats.database().params().global_descriptor()) {
    return stats.database().params().recognition().mode() == v1::RECOGNITION_MODE_RETRIEVAL
               ? "global       off: the retrieval mode runs without its global stage (create "
                 "the database with --global-descriptor)"
               : "global       off";
  }
  const int trained = stats.vocabulary_views();
  if (trained == 0) {
    return fmt::format("global       on, no vocabulary yet: learnt at {} views, the database "
                       "holds {}; until then the retrieval mode runs without its global stage",
                       kFirstVocabularyViews, views);
  }
  std::string next = "the last (it stays from now on)";
  if (trained < kLastVocabularyViews) {
    int at = kFirstVocabularyViews;
    while (at <= trained) at *= 2;
    next = fmt::format("the next at {} views", at);
  }
  return fmt::format("global       on, vocabulary learnt from {} views ({}), {} of {} views coded",
                     trained, next, stats.coded_views(), views);
}

int RunStats(CommandContext& context, const std::string& name) {
  v1::GetDatabaseStatsRequest request;
  request.set_name(name);
  auto stats = context.Connect()->GetDatabaseStats(request);
  if (!stats.ok()) return ReportError(context, stats.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*stats));
    return kExitOk;
  }
  PrintDatabase(context.out, stats->database());
  context.out << fmt::format("features     {} keypoints, {} of descriptors\n", stats->keypoints(),
                             FormatBytes(stats->descriptor_bytes()));
  context.out << GlobalStageLine(*stats) << "\n";
  if (!stats->crossing_list().empty()) {
    context.out << "\n";
    Table crossings({{"crossing"}, {"views", true}, {"label"}});
    for (const v1::Crossing& c : stats->crossing_list()) {
      crossings.AddRow({c.name(), std::to_string(c.views()), c.label()});
    }
    crossings.Print(context.out);
  }
  if (!stats->clusters().empty()) {
    context.out << "\n";
    Table clusters({{"cluster", true}, {"centre view", true}, {"members", true}});
    for (const v1::ClusterInfo& c : stats->clusters()) {
      clusters.AddRow({std::to_string(c.id()), std::to_string(c.center_view_id()),
                       std::to_string(c.members())});
    }
    clusters.Print(context.out);
  }
  return kExitOk;
}

int RunDelete(CommandContext& context, const std::string& name) {
  v1::DeleteDatabaseRequest request;
  request.set_name(name);
  auto response = context.Connect()->DeleteDatabase(request);
  if (!response.ok()) return ReportError(context, response.status());
  if (context.globals.json) {
    PrintJson(context.out, {{"deleted", name}});
  } else {
    context.out << "deleted database " << name << "\n";
  }
  return kExitOk;
}

struct RebuildArgs {
  std::string name;
  int cluster_threshold = 0;
  CLI::Option* cluster_threshold_option = nullptr;
};

int RunRebuild(CommandContext& context, const RebuildArgs& args) {
  v1::RebuildClustersRequest request;
  request.set_database(args.name);
  if (args.cluster_threshold_option->count() > 0) {
    request.set_cluster_threshold(args.cluster_threshold);
  }
  auto response = context.Connect()->RebuildClusters(request);
  if (!response.ok()) return ReportError(context, response.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*response));
  } else {
    context.out << fmt::format("rebuilt {}: {} views in {} clusters ({:.0f} ms)\n", args.name,
                               response->views(), response->clusters(), response->elapsed_ms());
  }
  return kExitOk;
}

}  // namespace

void AddDbCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* db = app.add_subcommand("db", "Create, list, inspect and delete crossing databases");
  db->require_subcommand(1);

  auto create_args = std::make_shared<CreateArgs>();
  CLI::App* create = db->add_subcommand("create", "Create an empty crossing database");
  create->add_option("NAME", create_args->name, "Database name")->required();
  create_args->work_width_option =
      create->add_option("--work-width", create_args->work_width, "Working resolution width [320]")
          ->check(CLI::PositiveNumber);
  create_args->work_height_option =
      create->add_option("--work-height", create_args->work_height, "Working height [240]")
          ->check(CLI::PositiveNumber);
  create_args->hue_bins_option =
      create->add_option("--hue-bins", create_args->hue_bins, "Hue histogram bins [36]")
          ->check(CLI::PositiveNumber);
  create_args->cluster_threshold_option =
      create
          ->add_option("--cluster-threshold", create_args->cluster_threshold,
                       "Matches for a view to join a cluster [5]")
          ->check(CLI::PositiveNumber);
  create_args->max_keypoints_option =
      create
          ->add_option("--max-keypoints", create_args->max_keypoints,
                       "Keypoints kept per image, 0 = all [0]")
          ->check(CLI::NonNegativeNumber);
  create_args->keep_aspect_option = create->add_flag(
      "--keep-aspect,!--no-keep-aspect", create_args->keep_aspect,
      "Fit images into the working size keeping their aspect ratio (the paper squeezes them to "
      "it) [on in retrieval mode]");
  create_args->root_sift_option =
      create->add_flag("--root-sift,!--no-root-sift", create_args->root_sift,
                       "RootSIFT descriptors [on in retrieval mode]");
  create_args->global_descriptor_option = create->add_flag(
      "--global-descriptor,!--no-global-descriptor", create_args->global_descriptor,
      "Keep a global descriptor of every view for the retrieval mode's shortlist [on with --mode "
      "retrieval]");
  create_args->mode_option = AddModeOption(create, &create_args->mode);
  registry.Add(create, [create_args](CommandContext& c) { return RunCreate(c, *create_args); });

  CLI::App* list = db->add_subcommand("list", "List databases");
  registry.Add(list, [](CommandContext& c) { return RunList(c); });

  auto stats_name = std::make_shared<std::string>();
  CLI::App* stats =
      db->add_subcommand("stats", "Crossings, views, clusters, keypoints and memory of a database");
  stats->add_option("NAME", *stats_name, "Database name")->required();
  registry.Add(stats, [stats_name](CommandContext& c) { return RunStats(c, *stats_name); });

  auto delete_name = std::make_shared<std::string>();
  CLI::App* remove = db->add_subcommand("delete", "Delete a database and all its views");
  remove->add_option("NAME", *delete_name, "Database name")->required();
  registry.Add(remove, [delete_name](CommandContext& c) { return RunDelete(c, *delete_name); });

  auto rebuild_args = std::make_shared<RebuildArgs>();
  CLI::App* rebuild = db->add_subcommand(
      "rebuild", "Re-run the clustering over all views (after deletions or a threshold change)");
  rebuild->add_option("NAME", rebuild_args->name, "Database name")->required();
  rebuild_args->cluster_threshold_option =
      rebuild
          ->add_option("--cluster-threshold", rebuild_args->cluster_threshold,
                       "New threshold, stored as the database's default")
          ->check(CLI::PositiveNumber);
  registry.Add(rebuild, [rebuild_args](CommandContext& c) { return RunRebuild(c, *rebuild_args); });
}

}  // namespace waymark::cli
