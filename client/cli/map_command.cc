// `waymark map create|list|show|grid|delete NAME`: maps shared by robots (issue 38), named and
// kept by the server beside the sessions. A robot's session joins one when it is created
// (`waymark slam replay LOG --map NAME`). Names in this file are prefixed Map*: the command files
// are compiled in unity batches, where anonymous-namespace names must not repeat across files.
#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "client/cli/command.h"
#include "client/cli/map_frame.h"
#include "client/common/output.h"
#include "client/common/proto_json.h"
#include "client/render/slam_output.h"

namespace waymark::cli {
namespace {

struct MapCommandArgs {
  std::string name;
  bool force = false;
  std::string out;                    // grid: output folder
  std::optional<double> resolution;  // grid: m per cell; unset = the server's default
};

std::string MapTime(int64_t unix_seconds) {
  if (unix_seconds <= 0) return "-";
  return absl::FormatTime("%Y-%m-%d %H:%M:%S", absl::FromUnixSeconds(unix_seconds),
                          absl::LocalTimeZone());
}

int MapTiedIn(const v1::Map& map) {
  int tied = 0;
  for (const v1::MapTrajectory& trajectory : map.trajectories()) tied += trajectory.tied_in();
  return tied;
}

// "office: 3 trajectories (1 tied in, 2 not yet in the map), revision 5"
std::string MapSummary(const v1::Map& map) {
  const int tied = MapTiedIn(map);
  const int untied = map.trajectories_size() - tied;
  if (map.trajectories_size() == 0) {
    return fmt::format("{}: no trajectories yet, revision {}", map.name(), map.revision());
  }
  return fmt::format("{}: {} trajector{} ({} tied in, {} not yet in the map), revision {}",
                     map.name(), map.trajectories_size(),
                     map.trajectories_size() == 1 ? "y" : "ies", tied, untied, map.revision());
}

int RunMapCreate(CommandContext& context, const MapCommandArgs& args) {
  auto map = context.ConnectSlam()->CreateMap(args.name);
  if (!map.ok()) return ReportError(context, map.status(), "CreateMap");
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*map));
  } else {
    context.out << fmt::format("created map {} (join it with `waymark slam replay LOG --map {}`)\n",
                               map->name(), map->name());
  }
  return kExitOk;
}

int RunMapList(CommandContext& context) {
  auto maps = context.ConnectSlam()->ListMaps();
  if (!maps.ok()) return ReportError(context, maps.status(), "ListMaps");
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*maps));
    return kExitOk;
  }
  if (maps->maps().empty()) {
    context.out << "no maps\n";
    return kExitOk;
  }
  Table table({{"map"}, {"trajectories", true}, {"tied in", true}, {"revision", true},
               {"created"}, {"updated"}});
  for (const v1::Map& map : maps->maps()) {
    table.AddRow({map.name(), std::to_string(map.trajectories_size()),
                  std::to_string(MapTiedIn(map)), std::to_string(map.revision()),
                  MapTime(map.created_at_unix()), MapTime(map.updated_at_unix())});
  }
  table.Print(context.out);
  return kExitOk;
}

int RunMapShow(CommandContext& context, const MapCommandArgs& args) {
  auto map = context.ConnectSlam()->GetMapInfo(args.name);
  if (!map.ok()) return ReportError(context, map.status(), "GetMapInfo");
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*map));
    return kExitOk;
  }
  context.out << MapSummary(*map) << "\n";
  // Only on a fleet: the server that ties and follows the map's robots.
  if (!map->owner().empty()) context.out << "tied and followed by the server at " << map->owner() << "\n";
  if (map->trajectories().empty()) return kExitOk;
  Table table({{"#", true}, {"session"}, {"robot"}, {"state"}, {"scans", true}, {"in the map"},
               {"matches"}, {"joined"}});
  int index = 0;
  for (const v1::MapTrajectory& t : map->trajectories()) {
    const std::string place =
        t.tied_in() ? fmt::format("yes, origin ({:.3f}, {:.3f}, {:.3f})", t.origin().x(),
                                  t.origin().y(), t.origin().theta())
                    : "not yet";
    // Searches while not in the map, follow-up matches after the tie.
    const v1::MapMatchStats& m = t.tied_in() ? t.follow() : t.search();
    const std::string matches =
        m.tried() == 0 ? "-"
                       : fmt::format("{} of {} {}{}", m.matched(), m.tried(),
                                     t.tied_in() ? "held" : "unique",
                                     m.ambiguous() > 0
                                         ? fmt::format(", {} look-alike", m.ambiguous())
                                         : "");
    table.AddRow({std::to_string(++index), t.session_id(), t.robot_id(),
                  t.state() == v1::Session::OPEN ? "open" : "closed",
                  std::to_string(t.scans_processed()), place, matches,
                  MapTime(t.joined_at_unix())});
  }
  table.Print(context.out);
  // The map's doubts, one line each, where people read them.
  for (const v1::MapTrajectory& t : map->trajectories()) {
    if (!t.warning().empty()) {
      context.out << "warning: robot " << t.robot_id() << " (session " << t.session_id()
                  << "): " << t.warning() << "\n";
    }
  }
  return kExitOk;
}

int RunMapGrid(CommandContext& context, const MapCommandArgs& args) {
  auto client = context.ConnectSlam();
  auto grid = client->GetMapOccupancyGrid(args.name, args.resolution);
  if (!grid.ok()) return ReportError(context, grid.status(), "GetMapOccupancyGrid");
  // The trajectories drawn on occupancy.png: the tied-in sessions', each moved into the map
  // frame as `slam trajectory --frame map` does.
  auto map = client->GetMapInfo(args.name, /*node_origins=*/true);
  if (!map.ok()) return ReportError(context, map.status(), "GetMap");
  v1::Trajectory trajectory;
  for (const std::string& session_id : grid->session_ids()) {
    auto poses = client->GetTrajectory(session_id);
    if (!poses.ok()) return ReportError(context, poses.status(), "GetTrajectory");
    for (const v1::MapTrajectory& t : map->trajectories()) {
      if (t.session_id() == session_id && t.tied_in()) MoveToMapFrame(t, &*poses);
    }
    for (const v1::TrajectoryPose& pose : poses->poses()) *trajectory.add_poses() = pose;
  }
  const std::filesystem::path dir =
      args.out.empty() ? std::filesystem::path("out") / "maps" / args.name
                       : std::filesystem::path(args.out);
  auto written = WriteGridFiles(dir, grid->grid(), trajectory);
  if (!written.ok()) return ReportError(context, written.status(), dir.string());
  // The merged segment map beside the grid: map.svg and map.png, as a session's.
  auto segments = client->GetMapSegments(args.name);
  if (!segments.ok()) return ReportError(context, segments.status(), "GetMapSegments");
  v1::SegmentMap segment_map;
  segment_map.set_map_revision(segments->revision());
  *segment_map.mutable_segments() = segments->segments();
  const std::filesystem::path svg = dir / "map.svg", png = dir / "map.png";
  if (absl::Status s = WriteMapPictures(
          SlamScene(segment_map, trajectory,
                    fmt::format("map {}: {} segments of {} trajector{} ({} fused)", args.name,
                                segments->segments_size(), segments->session_ids_size(),
                                segments->session_ids_size() == 1 ? "y" : "ies",
                                segments->fused_segments())),
          svg, png);
      !s.ok()) {
    return ReportError(context, s, svg.string());
  }
  written->push_back(svg);
  written->push_back(png);
  if (context.globals.json) {
    nlohmann::json files = nlohmann::json::array();
    for (const auto& file : *written) files.push_back(file.string());
    nlohmann::json sessions = nlohmann::json::array();
    for (const std::string& id : grid->session_ids()) sessions.push_back(id);
    PrintJson(context.out,
              {{"map", grid->map()},
               {"revision", grid->revision()},
               {"width", grid->grid().width()},
               {"height", grid->grid().height()},
               {"resolution", grid->grid().resolution()},
               {"origin", {grid->grid().origin().x(), grid->grid().origin().y()}},
               {"scans", grid->grid().scans()},
               {"session_ids", sessions},
               {"untied_trajectories", grid->untied_trajectories()},
               {"segments", segments->segments_size()},
               {"fused_segments", segments->fused_segments()},
               {"out_dir", dir.string()},
               {"files", files}});
  } else {
    context.out << fmt::format(
        "map {} (revision {}): {} x {} cells at {:g} m from {} scans of {} tied-in trajector{}{}; "
        "{} segments ({} fused: walls several robots mapped): wrote {}\n",
        grid->map(), grid->revision(), grid->grid().width(), grid->grid().height(),
        grid->grid().resolution(), grid->grid().scans(), grid->session_ids_size(),
        grid->session_ids_size() == 1 ? "y" : "ies",
        grid->untied_trajectories() > 0
            ? fmt::format(" ({} not yet in the map, not drawn)", grid->untied_trajectories())
            : "",
        segments->segments_size(), segments->fused_segments(), DescribeWritten(*written));
  }
  return kExitOk;
}

int RunMapDelete(CommandContext& context, const MapCommandArgs& args) {
  auto deleted = context.ConnectSlam()->DeleteMap(args.name, args.force);
  if (!deleted.ok()) return ReportError(context, deleted.status(), "DeleteMap");
  if (context.globals.json) {
    PrintJson(context.out, ProtoToJson(*deleted));
  } else {
    context.out << fmt::format("deleted map {} ({} trajectories; their sessions are kept{})\n",
                               deleted->map().name(), deleted->map().trajectories_size(),
                               deleted->detached_sessions() > 0
                                   ? fmt::format(", {} open ones detached",
                                                 deleted->detached_sessions())
                                   : "");
  }
  return kExitOk;
}

}  // namespace

void AddMapCommands(CLI::App& app, CommandRegistry& registry) {
  CLI::App* map = app.add_subcommand(
      "map",
      "Maps shared by robots: named maps on the server that laser sessions join (`slam replay "
      "LOG --map NAME`), one trajectory per session");
  map->require_subcommand(1);
  const std::string name_help =
      "Map name: 1-64 characters of A-Z a-z 0-9 . _ -, starting with a letter or digit";

  auto create_args = std::make_shared<MapCommandArgs>();
  CLI::App* create = map->add_subcommand("create", "Create an empty map (mapper or admin token)");
  create->add_option("NAME", create_args->name, name_help)->required();
  registry.Add(create, [create_args](CommandContext& c) { return RunMapCreate(c, *create_args); });

  CLI::App* list = map->add_subcommand("list", "List the maps");
  registry.Add(list, [](CommandContext& c) { return RunMapList(c); });

  auto show_args = std::make_shared<MapCommandArgs>();
  CLI::App* show = map->add_subcommand(
      "show", "A map's revision and trajectories: each session, its robot, whether it is in the map");
  show->add_option("NAME", show_args->name, name_help)->required();
  registry.Add(show, [show_args](CommandContext& c) { return RunMapShow(c, *show_args); });

  auto grid_args = std::make_shared<MapCommandArgs>();
  CLI::App* grid = map->add_subcommand(
      "grid",
      "Write the map's occupancy grid in the map frame as map.pgm + map.yaml (ROS map_server) "
      "and occupancy.png, and its segment map (walls several robots mapped fused into one) as "
      "map.svg + map.png: its tied-in trajectories");
  grid->add_option("NAME", grid_args->name, name_help)->required();
  grid->add_option("--out", grid_args->out, "Output folder (default ./out/maps/<name>)");
  grid->add_option_function<double>(
          "--resolution", [grid_args](const double& value) { grid_args->resolution = value; },
          "Occupancy grid cell size in metres, 0.01 to 1 (default: the server's, 0.05)")
      ->check(CLI::Range(0.01, 1.0));
  registry.Add(grid, [grid_args](CommandContext& c) { return RunMapGrid(c, *grid_args); });

  auto delete_args = std::make_shared<MapCommandArgs>();
  CLI::App* remove = map->add_subcommand(
      "delete",
      "Delete a map (mapper or admin token); its sessions are kept. A map with an open session "
      "in it is refused unless --force, which detaches them");
  remove->add_option("NAME", delete_args->name, name_help)->required();
  remove->add_flag("--force", delete_args->force, "Detach open sessions instead of refusing");
  registry.Add(remove, [delete_args](CommandContext& c) { return RunMapDelete(c, *delete_args); });
}

}  // namespace waymark::cli
