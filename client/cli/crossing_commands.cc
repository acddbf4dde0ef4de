// `waymark crossing add|list|delete`: crossings inside a database.
#include <memory>
#include <string>

#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"

namespace waymark::cli {
namespace {

struct CrossingArgs {
  std::string database;
  std::string name;
  std::string label;
};

int RunAdd(CommandContext& context, const CrossingArgs& args) {
  v1::AddCrossingRequest request;
  request.set_database(args.database);
  request.set_name(args.name);
  request.set_label(args.label);
  auto crossing = context.Connect()->AddCrossing(request);
  if (!crossing.ok()) return ReportError(context, crossing.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*crossing));
  } else {
    context.out << "added crossing " << crossing->name() << " (id " << crossing->id() << ")\n";
  }
  return kExitOk;
}

int RunList(CommandContext& context, const CrossingArgs& args) {
  v1::ListCrossingsRequest request;
  request.set_database(args.database);
  auto list = context.Connect()->ListCrossings(request);
  if (!list.ok()) return ReportError(context, list.status());
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*list));
    return kExitOk;
  }
  if (list->crossings().empty()) {
    context.out << "no crossings in " << args.database << "\n";
    return kExitOk;
  }
  Table table({{"id", true}, {"crossing"}, {"views", true}, {"label"}});
  for (const v1::Crossing& c : list->crossings()) {
    table.AddRow({std::to_string(c.id()), c.name(), std::to_string(c.views()), c.label()});
  }
  table.Print(context.out);
  return kExitOk;
}

int RunDelete(CommandContext& context, const CrossingArgs& args) {
  v1::DeleteCrossingRequest request;
  request.set_database(args.database);
  request.set_name(args.name);
  auto response = context.Connect()->DeleteCrossing(request);
  if (!response.ok()) return ReportError(context, response.status());
  if (context.globals.json) {
    PrintJson(context.out, {{"deleted", args.name}, {"views_deleted", response->views_deleted()}});
  } else {
    context.out << "deleted crossing " << args.name << " and its " << response->views_deleted()
                << " views (`waymark db rebuild DB` regroups the remaining views)\n";
  }
  return kExitOk;
}

// DB and, unless `with_name` is false, NAME positionals.
void AddPositionals(CLI::App* command, CrossingArgs* args, bool with_name) {
  command->add_option("DB", args->database, "Database name")->required();
  if (with_name) command->add_option("NAME", args->name, "Crossing name")->required();
}

}  // namespace

void AddCrossingCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* crossing = app.add_subcommand("crossing", "Add, list and delete crossings");
  crossing->require_subcommand(1);

  auto add_args = std::make_shared<CrossingArgs>();
  CLI::App* add = crossing->add_subcommand("add", "Add an empty crossing");
  AddPositionals(add, add_args.get(), true);
  add->add_option("--label", add_args->label, "Free text, e.g. the street names");
  registry.Add(add, [add_args](CommandContext& c) { return RunAdd(c, *add_args); });

  auto list_args = std::make_shared<CrossingArgs>();
  CLI::App* list = crossing->add_subcommand("list", "List the crossings of a database");
  AddPositionals(list, list_args.get(), false);
  registry.Add(list, [list_args](CommandContext& c) { return RunList(c, *list_args); });

  auto delete_args = std::make_shared<CrossingArgs>();
  CLI::App* remove = crossing->add_subcommand("delete", "Delete a crossing and its views");
  AddPositionals(remove, delete_args.get(), true);
  registry.Add(remove, [delete_args](CommandContext& c) { return RunDelete(c, *delete_args); });
}

}  // namespace waymark::cli
