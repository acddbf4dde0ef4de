// `waymark eval relations TRAJECTORY RELATIONS`: the relations metric of Kummerle et al. 2009 on a
// TUM trajectory (relations_metric.h). Needs no server.
#include <memory>
#include <string>

#include "client/cli/command.h"
#include "client/common/output.h"
#include "client/eval/relations_metric.h"
#include "client/datasets/tum_trajectory.h"

namespace waymark::cli {
namespace {

struct RelationsArgs {
  std::string trajectory;
  std::string relations;
  double tolerance_s = 1e-3;
};

int RunRelations(CommandContext& context, const RelationsArgs& args) {
  auto trajectory = ReadTumFile(args.trajectory);
  if (!trajectory.ok()) return ReportError(context, trajectory.status());
  auto relations = ReadRelationsFile(args.relations);
  if (!relations.ok()) return ReportError(context, relations.status());
  const RelationsResult result = EvaluateRelations(*trajectory, *relations, args.tolerance_s);
  if (context.globals.json) {
    nlohmann::json json = RelationsResultToJson(result);
    json["trajectory"] = args.trajectory;
    json["relations_file"] = args.relations;
    json["poses"] = trajectory->size();
    json["tolerance_s"] = args.tolerance_s;
    PrintJson(context.out, json);
  } else {
    PrintRelationsResult(context.out, result);
  }
  if (result.relations_used < result.relations) {
    context.err << "warning: " << result.relations - result.relations_used << " of "
                << result.relations << " relations had no pose within " << args.tolerance_s
                << " s of a stamp (" << result.missing_t1 << " at t1, " << result.missing_t2
                << " at t2) and were left out\n";
  }
  return result.relations_used > 0 || result.relations == 0 ? kExitOk : kExitFailure;
}

}  // namespace

void AddEvalRelationsCommand(CLI::App& app, CommandRegistry& registry) {
  CLI::App* eval = app.get_subcommand("eval");
  auto args = std::make_shared<RelationsArgs>();
  CLI::App* relations = eval->add_subcommand(
      "relations",
      "SLAM accuracy by the relations metric (Kummerle et al. 2009): TRAJECTORY in TUM format "
      "(t x y z qx qy qz qw), RELATIONS lines 't1 t2 x y z roll pitch yaw'");
  relations->add_option("TRAJECTORY", args->trajectory, "Estimated trajectory, TUM format")
      ->required();
  relations->add_option("RELATIONS", args->relations, "Ground-truth relations file")->required();
  relations
      ->add_option("--tolerance", args->tolerance_s,
                   "Largest gap (s) between a relation stamp and the pose used for it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  registry.Add(relations, [args](CommandContext& c) { return RunRelations(c, *args); });
}

}  // namespace waymark::cli
