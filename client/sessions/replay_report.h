#ifndef WAYMARK_CLIENT_SESSIONS_REPLAY_REPORT_H_
#define WAYMARK_CLIENT_SESSIONS_REPLAY_REPORT_H_

// What `waymark slam replay` says when it ends: summary.json, the --json document and the lines
// for people, all from one ReplayReport, whether the replay ran to the end of the log or was cut
// short (Ctrl-C, a broken stream, an unreadable log).

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// Why the replay stopped sending.
enum class ReplayEnd {
  kEndOfLog,
  kMaxScans,     // --max-scans reached
  kInterrupted,  // Ctrl-C (or SIGTERM)
  kFailed,       // the stream broke or the log could not be read on
};

// "end of log", "max scans", "interrupted", "error".
const char* ReplayEndName(ReplayEnd end);

// A log laser scanner keeps scanning; a gap this long between two consecutive scans means the
// stamps are not a recording's clock (e.g. 4294967295 after -0.4 in infinite-corridor).
inline constexpr double kMaxPlausibleScanGapS = 600;

// The stamps of the scans sent, in order.
class StampSpan {
 public:
  void Add(double stamp);
  int64_t scans() const { return scans_; }
  double first_stamp() const { return first_; }
  double duration_s() const { return scans_ > 0 ? last_ - first_ : 0.0; }
  double max_gap_s() const { return max_gap_; }

 private:
  int64_t scans_ = 0;
  double first_ = 0;
  double last_ = 0;
  double max_gap_ = 0;
};

// Why the span cannot give a real-time factor (a phrase for "... not meaningful (PHRASE)"), or
// nullopt when it can.
std::optional<std::string> SpanProblem(const StampSpan& span, bool stamps_broken);

struct ReplayReport {
  std::string log;
  std::string session_id;
  ReplayEnd end = ReplayEnd::kEndOfLog;
  std::string error;            // kFailed: what went wrong
  bool session_closed = false;  // by this replay (else it is left open: the summary says how to)
  std::string close_error;      // why closing failed

  // The stream.
  uint64_t scans_sent = 0;
  uint64_t scans_answered = 0;  // processed (a rejection is not counted)
  uint64_t rejected = 0;
  uint64_t queue_full = 0;
  uint64_t skipped_motion = 0;
  int window = 0;
  int max_outstanding = 0;
  std::optional<double> server_ms_p50;
  std::optional<double> server_ms_p99;
  bool realtime = false;

  // The log.
  int64_t laser_lines = 0;  // read from the log
  int64_t skipped_stamps = 0;
  int64_t reordered_lines = 0;
  int64_t malformed_lines = 0;
  int64_t odometry_lines = 0;
  int odometry_lag_scans = 0;  // LaserSourceCounts::odometry_lag_scans
  bool stamps_broken = false;
  std::optional<double> restamp_rate_hz;  // set: stamps synthesized from the line order
  // A bag's facts (format, scan topic, odometry source, frames, the laser's mounting); empty for a
  // CARMEN log. summary.json's "bag" object and a line for people.
  std::vector<std::pair<std::string, std::string>> source_facts;
  StampSpan span;
  double processing_s = 0;  // the stream: first scan sent to last answer
  double close_s = 0;       // CloseSession: the back end's last searches and optimisation
  uint64_t loop_closures = 0;  // in the final graph (GetMap), else as the last answers said
  uint64_t graph_nodes = 0;    // the final graph's scan nodes (GetMap)
  uint64_t pruned_nodes = 0;   // of those, pruned (their submaps added nothing new)

  // The results and where they went.
  int segments = 0;
  uint64_t map_revision = 0;
  int trajectory_poses = 0;
  std::string trajectory_source = "server";  // or "stream answers" when the server could not say
  std::string map_problem;                   // why the pictures have no map (empty: they have it)
  std::filesystem::path out;
  bool out_is_folder = true;
  std::vector<std::filesystem::path> files;  // written, summary.json included
  std::string write_error;                   // why the outputs could not be written
  // The occupancy grid (map.pgm, map.yaml, occupancy.png): its size when written, else why not
  // (a note: a replay never fails for its grid).
  uint32_t grid_width = 0;  // 0 = not written
  uint32_t grid_height = 0;
  double grid_resolution = 0;
  std::string grid_note;
  // The map's self-check as GetMap answered it after closing (docs/laser-slam.md, "A map that
  // checks itself"); unset when the map has none (loop closure off, a localization session, a
  // server older than it) or the map could not be had. Only a closed session's map of a replay
  // that was not cut short is final: a map in the making contradicts itself until its loops close.
  std::optional<v1::MapSelfCheck> self_check;
  // --allow-inconsistent-map: a final map that contradicts itself is warned about, not an exit 3.
  bool allow_inconsistent_map = false;

  // Localization sessions: the scans answered with localization.localized, and the first of them
  // (its index among the answered scans, 0 = the first, and its stamp): the time to first fix.
  std::string localize_map;  // the map session; empty for a mapping session
  uint64_t localized_scans = 0;
  // Answers that carried a localization status at all: none means the server did not localize
  // (one older than LaserSlamConfig.localize ignores it and maps).
  uint64_t localization_statuses = 0;
  std::optional<uint64_t> first_fix_scan;
  std::optional<double> first_fix_stamp;
  // The first fix's confidence (LocalizationStatus): its score, and its best rival's score over
  // it (0 = none near it) and distance from it (m).
  std::optional<double> first_fix_score;
  std::optional<double> first_fix_rival_ratio;
  std::optional<double> first_fix_rival_distance;
  // Answers not localized because another place fit nearly as well (state AMBIGUOUS).
  uint64_t ambiguous_answers = 0;
  // Localization: the pictures draw the map localized on (localize_map's segments and occupancy
  // grid) with this run's trajectory, not this session's own (it keeps no scans). How many of its
  // segments were drawn, and why it could not be had when map_drawn is false.
  bool map_drawn = false;
  int drawn_segments = 0;
  std::string drawn_map_problem;

  // --map: the shared map the session joined and its trajectory there after the replay
  // (GetMapInfo): tied in, or not yet in the map; map_note says why the map could not be read.
  std::string shared_map;  // empty: the session joined no map
  bool shared_map_tied_in = false;
  int shared_map_trajectory = 0;  // its place in the join order, 1 = the first
  int shared_map_trajectories = 0;
  uint64_t shared_map_revision = 0;
  uint64_t map_pose_answers = 0;  // answers that carried map_pose
  uint64_t map_pose_tied = 0;     // of which tied in (a map-frame pose)
  std::string shared_map_note;
  // --scans FIRST:LAST as given ("" = all).
  std::string scan_slice;

  bool partial() const { return end == ReplayEnd::kInterrupted || end == ReplayEnd::kFailed; }
};

// The summary.json / --json document.
nlohmann::json ReplayJson(const ReplayReport& report);

// The lines for people on stdout.
std::string ReplayText(const ReplayReport& report);

// The sentence naming a session left open and how to close (or delete) it.
std::string LeftOpenAdvice(const std::string& session_id);

// The final map (closed, not cut short) contradicts itself: what exits kExitInconsistentMap unless
// --allow-inconsistent-map.
bool FinalMapContradictsItself(const ReplayReport& report);

// The WARNING lines for stderr when FinalMapContradictsItself (the verdict, the worst areas, where
// the pictures show them, the exit code); empty otherwise.
std::string InconsistentMapWarning(const ReplayReport& report);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_REPLAY_REPORT_H_
