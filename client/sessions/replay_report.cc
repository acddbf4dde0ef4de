#include "client/sessions/replay_report.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include "client/common/output.h"
#include "client/render/slam_output.h"

namespace waymark::cli {

const char* ReplayEndName(ReplayEnd end) {
  switch (end) {
    case ReplayEnd::kEndOfLog: return "end of log";
    case ReplayEnd::kMaxScans: return "max scans";
    case ReplayEnd::kInterrupted: return "interrupted";
    case ReplayEnd::kFailed: return "error";
  }
  return "error";
}

void StampSpan::Add(double stamp) {
  if (scans_ == 0) {
    first_ = stamp;
  } else {
    max_gap_ = std::max(max_gap_, stamp - last_);
  }
  last_ = stamp;
  ++scans_;
}

std::optional<std::string> SpanProblem(const StampSpan& span, bool stamps_broken) {
  if (stamps_broken) return "most stamps were skipped";
  if (span.scans() < 2) return "fewer than two scans";
  if (!(span.duration_s() > 0)) return "the stamps do not advance";
  if (span.max_gap_s() > kMaxPlausibleScanGapS) {
    return fmt::format("{:.0f} s between two consecutive scans, more than {:.0f} s", span.max_gap_s(),
                       kMaxPlausibleScanGapS);
  }
  return std::nullopt;
}

namespace {

// The real-time factor, or why there is none.
struct RealtimeFactor {
  std::optional<double> value;
  std::string problem;
};

RealtimeFactor FactorOf(const ReplayReport& report) {
  if (auto problem = SpanProblem(report.span, report.stamps_broken)) {
    return {std::nullopt, "the log's time span is not meaningful: " + *problem};
  }
  if (!(report.processing_s > 0)) return {std::nullopt, "no processing time was measured"};
  return {report.span.duration_s() / report.processing_s, ""};
}

// Seconds from the first scan sent to the first localized one.
std::optional<double> TimeToFirstFix(const ReplayReport& report) {
  if (!report.first_fix_stamp) return std::nullopt;
  return *report.first_fix_stamp - report.span.first_stamp();
}

nlohmann::json LocalizationJson(const ReplayReport& report) {
  return {{"map_session_id", report.localize_map},
          {"localized_scans", report.localized_scans},
          {"answers_with_status", report.localization_statuses},
          {"first_fix_scan", report.first_fix_scan ? nlohmann::json(*report.first_fix_scan)
                                                   : nlohmann::json(nullptr)},
          {"first_fix_stamp", OptionalJson(report.first_fix_stamp)},
          {"time_to_first_fix_s", OptionalJson(TimeToFirstFix(report))},
          {"first_fix_score", OptionalJson(report.first_fix_score)},
          {"first_fix_rival_ratio", OptionalJson(report.first_fix_rival_ratio)},
          {"first_fix_rival_distance_m", OptionalJson(report.first_fix_rival_distance)},
          {"ambiguous_answers", report.ambiguous_answers},
          // What the pictures draw: the map localized on (segments and grid) under this run's
          // trajectory.
          {"drawn_map", report.map_drawn ? nlohmann::json(report.localize_map)
                                         : nlohmann::json(nullptr)},
          {"drawn_segments", report.drawn_segments},
          {"drawn_map_problem", report.drawn_map_problem.empty()
                                    ? nlohmann::json(nullptr)
                                    : nlohmann::json(report.drawn_map_problem)}};
}

// What a localization replay's pictures show: the map it localized on.
std::string DrawnMapText(const ReplayReport& report) {
  if (!report.map_drawn) {
    return fmt::format("the pictures show only this run's trajectory: map {} could not be read "
                       "({})\n",
                       report.localize_map, report.drawn_map_problem);
  }
  std::string grid = report.grid_width > 0
                         ? fmt::format("its occupancy grid ({} x {} cells of {:g} m) and ",
                                       report.grid_width, report.grid_height,
                                       report.grid_resolution)
                         : std::string();
  return fmt::format("the pictures show the map localized on, {}: {}its {} segments, with this "
                     "run's trajectory\n",
                     report.localize_map, grid, report.drawn_segments);
}

std::string LocalizationText(const ReplayReport& report) {
  std::string text =
      fmt::format("localization on map {}: {} of {} scans localized", report.localize_map,
                  report.localized_scans, report.scans_answered);
  if (report.first_fix_scan && report.first_fix_stamp) {
    text += fmt::format(", first fix at scan {} (stamp {:.3f}, {:.2f} s after the first scan)",
                        *report.first_fix_scan, *report.first_fix_stamp, *TimeToFirstFix(report));
    if (report.first_fix_score) {
      text += fmt::format(" scoring {:.2f}", *report.first_fix_score);
      if (report.first_fix_rival_ratio.value_or(0) > 0) {
        text += fmt::format(", its best rival {:.2f} of that {:.1f} m away",
                            *report.first_fix_rival_ratio,
                            report.first_fix_rival_distance.value_or(0));
      } else {
        text += ", no rival place near that score";
      }
    }
  } else if (report.scans_answered > 0 && report.localization_statuses == 0) {
    text +=
        ": no answer carried a localization status (a server older than --localize-on maps "
        "instead)";
  } else {
    text += ", never localized";
  }
  if (report.ambiguous_answers > 0) {
    text += fmt::format(
        "; {} answers refused a fix because another place fit nearly as well (ambiguous)",
        report.ambiguous_answers);
  }
  return text + "\n";
}

}  // namespace

std::string LeftOpenAdvice(const std::string& session_id) {
  return fmt::format(
      "session {0} was left open: close it with `waymark slam close {0}` (its map and trajectory "
      "stay readable), or delete it with `waymark slam delete {0} --force`",
      session_id);
}

namespace {

// The map a replay ends with is judged only when it is the log's final map: the session closed
// (the back end's last optimisation ran) and the replay not cut short.
bool FinalMap(const ReplayReport& report) { return report.session_closed && !report.partial(); }

nlohmann::json SelfCheckJson(const ReplayReport& report) {
  if (!report.self_check) return nullptr;
  const v1::MapSelfCheck& check = *report.self_check;
  nlohmann::json areas = nlohmann::json::array();
  for (const v1::MapCheckArea& area : check.worst_areas()) {
    areas.push_back({{"min", {area.min_x(), area.min_y()}},
                     {"size_m", area.size()},
                     {"contradicted_fraction", area.contradicted_fraction()},
                     {"contradicted", area.contradicted()},
                     {"evidence", area.evidence()}});
  }
  return {{"consistent", check.consistent()},
          {"verdict", check.verdict()},
          {"final_map", FinalMap(report)},
          {"fails_replay", FinalMapContradictsItself(report) && !report.allow_inconsistent_map},
          {"contradicted_fraction", check.contradicted_fraction()},
          {"areas_contradicting", check.areas_contradicting()},
          {"worst_areas", areas},
          {"contradicted", check.contradicted()},
          {"evidence", check.evidence()},
          {"baseline_fraction", check.baseline_fraction()},
          {"contradicting_cells", check.contradicting_cell_count()},
          {"nodes", check.nodes()},
          {"submaps", check.submaps()},
          {"resolution_m", check.resolution()}};
}

std::string SelfCheckText(const ReplayReport& report) {
  if (!report.self_check) return "";
  std::string text = "map self-check: " + report.self_check->verdict();
  if (!FinalMap(report)) {
    text += report.session_closed ? " (the replay was cut short: not the log's final map)"
                                  : " (the session is still open: not its final map)";
  }
  return text + "\n";
}

}  // namespace

bool FinalMapContradictsItself(const ReplayReport& report) {
  return report.self_check && !report.self_check->consistent() && FinalMap(report);
}

std::string InconsistentMapWarning(const ReplayReport& report) {
  if (!FinalMapContradictsItself(report)) return "";
  const v1::MapSelfCheck& check = *report.self_check;
  std::string text = fmt::format(
      "WARNING: the final map contradicts itself: {} areas contradict themselves and {:.1f}% of "
      "its wall cells are contradicted both ways (a wrong loop closure folds a map: a corridor "
      "drawn twice, or across itself).\n",
      check.areas_contradicting(), 100.0 * check.contradicted_fraction());
  if (check.worst_areas_size() > 0) {
    std::vector<std::string> areas;
    for (int i = 0; i < std::min(3, check.worst_areas_size()); ++i) {
      const v1::MapCheckArea& a = check.worst_areas(i);
      areas.push_back(fmt::format("x {:g}..{:g}, y {:g}..{:g} m ({:.0f}%)", a.min_x(),
                                  a.min_x() + a.size(), a.min_y(), a.min_y() + a.size(),
                                  100.0 * a.contradicted_fraction()));
    }
    text += fmt::format("WARNING: the worst areas: {}{}.\n", fmt::join(areas, "; "),
                        report.grid_width > 0
                            ? "; occupancy.png outlines them in orange, the contradicting "
                              "cells in red"
                            : "");
  }
  text += report.allow_inconsistent_map
              ? "WARNING: --allow-inconsistent-map: exit code 0 all the same.\n"
              : "WARNING: exit code 3 (--allow-inconsistent-map exits 0 for such a map).\n";
  return text;
}

nlohmann::json ReplayJson(const ReplayReport& report) {
  const RealtimeFactor factor = FactorOf(report);
  nlohmann::json files = nlohmann::json::array();
  for (const auto& file : report.files) files.push_back(file.string());
  nlohmann::json json = {
      {"log", report.log},
      {"session_id", report.session_id},
      {"partial", report.partial()},
      {"stopped", ReplayEndName(report.end)},
      {"error", report.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(report.error)},
      {"session_closed", report.session_closed},
      {"scans", report.scans_answered},
      {"scans_sent", report.scans_sent},
      {"scans_skipped_motion", report.skipped_motion},
      {"rejected", report.rejected},
      {"queue_full", report.queue_full},
      {"laser_lines", report.laser_lines},
      {"skipped_stamps", report.skipped_stamps},
      {"stamps_broken", report.stamps_broken},
      {"stamps", report.restamp_rate_hz ? "synthesized" : "log"},
      {"restamp_rate_hz", OptionalJson(report.restamp_rate_hz)},
      {"reordered_lines", report.reordered_lines},
      {"malformed_lines", report.malformed_lines},
      {"odometry_lines_not_sent", report.odometry_lines},
      {"odometry_lag_scans", report.odometry_lag_scans},
      {"segments", report.segments},
      {"map_revision", report.map_revision},
      {"trajectory_poses", report.trajectory_poses},
      {"trajectory_source", report.trajectory_source},
      {"processing_s", report.processing_s},
      {"close_s", report.close_s},
      {"final_map_realtime_factor",
       report.session_closed && report.processing_s + report.close_s > 0 &&
               report.span.duration_s() > 0 && !report.restamp_rate_hz
           ? nlohmann::json(report.span.duration_s() / (report.processing_s + report.close_s))
           : nlohmann::json(nullptr)},
      {"loop_closures", report.loop_closures},
      {"graph_nodes", report.graph_nodes},
      {"pruned_nodes", report.pruned_nodes},
      {"log_duration_s", report.span.duration_s()},
      {"realtime_factor", OptionalJson(factor.value)},
      {"window", report.window},
      {"max_outstanding", report.max_outstanding},
      {"server_ms_p50", OptionalJson(report.server_ms_p50)},
      {"server_ms_p99", OptionalJson(report.server_ms_p99)},
      {"realtime", report.realtime},
      {report.out_is_folder ? "out_dir" : "out", report.out.string()},
      {"files", files},
  };
  json["grid"] = report.grid_width > 0 ? nlohmann::json{{"width", report.grid_width},
                                                        {"height", report.grid_height},
                                                        {"resolution", report.grid_resolution}}
                                       : nlohmann::json(nullptr);
  if (!report.grid_note.empty()) json["grid_note"] = report.grid_note;
  json["self_check"] = SelfCheckJson(report);
  if (!report.localize_map.empty()) json["localization"] = LocalizationJson(report);
  if (!report.shared_map.empty()) {
    json["shared_map"] = {{"name", report.shared_map},
                          {"tied_in", report.shared_map_tied_in},
                          {"trajectory", report.shared_map_trajectory},
                          {"trajectories", report.shared_map_trajectories},
                          {"revision", report.shared_map_revision},
                          {"map_pose_answers", report.map_pose_answers},
                          {"map_pose_tied", report.map_pose_tied}};
    if (!report.shared_map_note.empty()) json["shared_map"]["note"] = report.shared_map_note;
  }
  if (!report.scan_slice.empty()) json["scan_slice"] = report.scan_slice;
  if (!report.source_facts.empty()) {
    nlohmann::json bag = nlohmann::json::object();
    for (const auto& [key, value] : report.source_facts) bag[key] = value;
    json["bag"] = bag;
  }
  if (!factor.value) json["realtime_factor_note"] = factor.problem;
  if (!report.map_problem.empty()) json["map_problem"] = report.map_problem;
  if (!report.close_error.empty()) json["close_error"] = report.close_error;
  if (!report.write_error.empty()) json["write_error"] = report.write_error;
  return json;
}

std::string ReplayText(const ReplayReport& report) {
  std::string text;
  if (report.end == ReplayEnd::kInterrupted) {
    text += fmt::format("interrupted after {} scans sent, {} answered: the outputs are partial\n",
                        report.scans_sent, report.scans_answered);
  } else if (report.end == ReplayEnd::kFailed) {
    text += fmt::format("stopped by an error after {} scans sent, {} answered: {}; the outputs "
                        "are partial\n",
                        report.scans_sent, report.scans_answered, report.error);
  }
  if (!report.source_facts.empty()) {
    std::vector<std::string> facts;
    for (const auto& [key, value] : report.source_facts) {
      if (!value.empty()) facts.push_back(key + " " + value);
    }
    text += "bag: " + fmt::format("{}", fmt::join(facts, "; ")) + "\n";
  }
  text += fmt::format(
      "session {}: {} scans processed ({} sent, {} rejected, {} skipped stamps), {} segments\n",
      report.session_id, report.scans_answered, report.scans_sent, report.rejected,
      report.skipped_stamps, report.segments);
  const std::string server_ms =
      fmt::format("server p50 {} ms, p99 {} ms per scan", FormatNumber(report.server_ms_p50, 2),
                  FormatNumber(report.server_ms_p99, 2));
  const RealtimeFactor factor = FactorOf(report);
  if (report.restamp_rate_hz) {
    text += fmt::format("stamps synthesized from the log's line order at {:g} Hz (--restamp): "
                        "the log's own stamps were not used\n",
                        *report.restamp_rate_hz);
  }
  if (factor.value) {
    text += fmt::format("log {:.1f} s{} replayed in {:.2f} s: real-time factor {:.1f}x; {}\n",
                        report.span.duration_s(), report.restamp_rate_hz ? " (synthesized)" : "",
                        report.processing_s, *factor.value, server_ms);
  } else {
    text += fmt::format("replayed in {:.2f} s, no real-time factor ({}); {}\n", report.processing_s,
                        factor.problem, server_ms);
  }
  if (report.session_closed && report.close_s >= 0.5) {
    // The stream's answers come before the back end has caught up with them; say what the final
    // map cost.
    text += fmt::format("closing took {:.2f} s (the back end's last loop searches and "
                        "optimisation){}\n",
                        report.close_s,
                        factor.value ? fmt::format(": the final map after {:.2f} s, {:.1f}x real time",
                                                   report.processing_s + report.close_s,
                                                   report.span.duration_s() /
                                                       (report.processing_s + report.close_s))
                                     : std::string());
  }
  if (report.loop_closures > 0) text += fmt::format("loop closures: {}\n", report.loop_closures);
  if (report.pruned_nodes > 0) {
    text += fmt::format("pruned: {} of {} scan nodes (their submaps added nothing the map held)\n",
                        report.pruned_nodes, report.graph_nodes);
  }
  if (!report.map_problem.empty()) {
    text += "the map pictures show no segments: " + report.map_problem + "\n";
  }
  if (!report.grid_note.empty()) text += report.grid_note + "\n";
  text += SelfCheckText(report);
  if (!report.localize_map.empty()) text += LocalizationText(report) + DrawnMapText(report);
  if (!report.shared_map.empty()) {
    if (!report.shared_map_note.empty()) {
      text += fmt::format("map {}: {}\n", report.shared_map, report.shared_map_note);
    } else {
      text += fmt::format("map {}: trajectory {} of {}, {} (revision {}; {} of {} answers had a "
                          "map-frame pose)\n",
                          report.shared_map, report.shared_map_trajectory,
                          report.shared_map_trajectories,
                          report.shared_map_tied_in ? "tied in" : "not yet in the map",
                          report.shared_map_revision, report.map_pose_tied,
                          report.map_pose_answers);
    }
  }
  if (report.trajectory_source != "server") {
    text += fmt::format("trajectory: the {} poses of the {}\n", report.trajectory_poses,
                        report.trajectory_source);
  }
  if (!report.write_error.empty()) {
    text += "could not write the outputs: " + report.write_error + "\n";
  } else {
    text += "wrote " + DescribeWritten(report.files) + "\n";
  }
  if (!report.session_closed) {
    text += LeftOpenAdvice(report.session_id);
    if (!report.close_error.empty()) text += " (closing it failed: " + report.close_error + ")";
    text += "\n";
  } else if (report.partial()) {
    text += "session " + report.session_id + " closed\n";
  }
  return text;
}

}  // namespace waymark::cli
