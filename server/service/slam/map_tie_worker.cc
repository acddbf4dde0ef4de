#include "server/service/slam/map_tie_worker.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <iterator>
#include <set>
#include <utility>

#include "server/common/stopwatch.h"

namespace waymark::service {
namespace {

// Reads one session may spend in one turn: the others (and Stop) wait at most that long
// (20-60 ms here).
constexpr std::int64_t kTurnReads = 20'000'000;
// Windowed matches one followed session may make in one turn (each a few ms).
constexpr int kFollowAttempts = 20;

}  // namespace

MapTieWorker::MapTieWorker(Sources sources, Options options)
    : sources_(std::move(sources)), options_(std::move(options)) {
  thread_ = std::thread([this] { Loop(); });
}

MapTieWorker::~MapTieWorker() { Stop(); }

void MapTieWorker::Stop() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void MapTieWorker::Loop() {
  while (true) {
    bool more = false;
    try {
      more = Pass();
    } catch (const std::exception& e) {
      // Never let the thread die with the server running on (std::thread would terminate).
      spdlog::error("SLAM maps: tying trajectories in failed: {}", e.what());
    }
    std::unique_lock<std::mutex> lock(mu_);
    if (stop_) return;
    if (!more) {
      cv_.wait_for(lock, std::chrono::duration<double>(options_.poll_seconds),
                   [this] { return stop_; });
      if (stop_) return;
    }
  }
}

bool MapTieWorker::Moving(const storage::MapTrajectoryRecord& trajectory) const {
  if (sources_.resident(trajectory.session_id)) return true;
  auto it = stored_.find(trajectory.session_id);
  if (it == stored_.end()) return false;
  return trajectory.scans_processed > it->second.scans_processed ||
         (sources_.read_feed && trajectory.session_state != storage::SlamSessionState::kClosed);
}

std::optional<TrajectoryNodes> MapTieWorker::FedNodesOf(
    const storage::MapTrajectoryRecord& trajectory) {
  if (!sources_.read_feed) return std::nullopt;
  const std::string& session_id = trajectory.session_id;
  auto held = stored_.find(session_id);
  const TrajectoryNodes none;
  const TrajectoryNodes& nodes = held == stored_.end() ? none : held->second.nodes;
  const int64_t version = held == stored_.end() ? 0 : held->second.feed_version;
  // The points of the nodes held are kept; only newer nodes' are read.
  const int64_t after_scan =
      nodes.nodes.empty() ? 0 : static_cast<int64_t>(nodes.nodes.back().scan);
  for (const int64_t from : {after_scan, int64_t{0}}) {
    absl::StatusOr<std::optional<storage::TrajectoryFeed>> feed =
        sources_.read_feed(session_id, version, from);
    if (!feed.ok()) {
      spdlog::warn("SLAM maps: the nodes published for session {} are not readable: {}",
                   session_id, feed.status().ToString());
      return std::nullopt;
    }
    // None newer, or behind the checkpoint (its robot's server stopped publishing it).
    if (!feed->has_value() || (*feed)->scans_processed < trajectory.scans_processed) {
      return std::nullopt;
    }
    absl::StatusOr<TrajectoryNodes> joined = JoinFeed(nodes, **feed);
    if (joined.ok()) {
      stored_[session_id] = Stored{*joined, (*feed)->scans_processed, (*feed)->version};
      return *std::move(joined);
    }
    // A node older than those held and not among them (another server's first publish): read
    // every node's points once more, then give up on this feed.
    if (from == 0) {
      spdlog::warn("SLAM maps: the nodes published for session {}: {}", session_id,
                   joined.status().ToString());
    }
  }
  return std::nullopt;
}

absl::StatusOr<TrajectoryNodes> MapTieWorker::NodesOf(
    const storage::MapTrajectoryRecord& trajectory) {
  const std::string& session_id = trajectory.session_id;
  const bool resident = sources_.resident(session_id);
  if (!resident) {
    if (std::optional<TrajectoryNodes> fed = FedNodesOf(trajectory); fed.has_value()) {
      return *std::move(fed);
    }
  }
  int64_t feed_version = 0;
  if (auto it = stored_.find(session_id); it != stored_.end()) {
    // Nothing newer published, and no newer checkpoint: what is held.
    if (!resident && trajectory.scans_processed <= it->second.scans_processed) {
      return it->second.nodes;
    }
    feed_version = it->second.feed_version;
    stored_.erase(it);  // its robot came back here, or went on elsewhere: its nodes changed
  }
  absl::StatusOr<TrajectoryNodes> nodes = sources_.nodes(session_id);
  if (nodes.ok() && !nodes->resident) {
    stored_[session_id] = Stored{*nodes, trajectory.scans_processed, feed_version};
  }
  return nodes;
}

void MapTieWorker::PublishPass(const std::vector<storage::MapRecord>& maps) {
  if (options_.feed_seconds <= 0.0) return;
  const double now = SteadySeconds();
  std::set<std::string> published;
  for (const storage::MapRecord& map : maps) {
    // The owner reads the sessions in memory here directly. Not Owned(): publishing must never
    // take a map's lease (a server with nothing to tie or follow would then hold it).
    if (sources_.holds(map.name)) continue;
    for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
      const std::string& session_id = trajectory.session_id;
      if (!sources_.resident(session_id) || !published.insert(session_id).second) continue;
      Publishing& publishing = publishing_[session_id];
      if (now - publishing.at < options_.feed_seconds) continue;
      absl::StatusOr<TrajectoryNodes> nodes = sources_.nodes(session_id);
      if (!nodes.ok()) continue;  // closed or deleted meanwhile
      std::optional<storage::TrajectoryFeedUpdate> update = publishing.publisher.Update(*nodes);
      if (!update.has_value()) continue;
      absl::StatusOr<int64_t> version = sources_.publish(session_id, *update);
      if (!version.ok()) {
        spdlog::warn("SLAM map \"{}\": session {}'s nodes not published for its owner: {}",
                     map.name, session_id, version.status().ToString());
        continue;
      }
      if (!publishing.publisher.any()) {
        spdlog::info("SLAM map \"{}\": publishing session {}'s nodes for the server that owns "
                     "the map",
                     map.name, session_id);
      }
      publishing.publisher.Published(*update);
      publishing.at = now;
    }
  }
  // Sessions that left this server or whose map is owned here now: the next publish starts
  // afresh (it replaces what the feed held).
  for (auto it = publishing_.begin(); it != publishing_.end();) {
    it = published.count(it->first) ? std::next(it) : publishing_.erase(it);
  }
}

bool MapTieWorker::Pass() {
  const std::vector<storage::MapRecord> maps = sources_.maps_to_tie();
  std::set<std::string> untied, referenced;
  bool more = false;
  for (const storage::MapRecord& map : maps) {
    if (!Owned(map.name)) continue;  // another server of the fleet ties its robots in
    std::vector<laser_slam::TiedTrajectory> tied;
    std::size_t map_nodes = 0;
    for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
      referenced.insert(trajectory.session_id);
      if (!trajectory.tie) continue;
      absl::StatusOr<TrajectoryNodes> nodes = NodesOf(trajectory);
      if (!nodes.ok()) continue;  // deleted meanwhile: the map no longer holds it
      map_nodes += nodes->nodes.size();
      tied.push_back(laser_slam::TiedTrajectory{
          laser_slam::Pose2{trajectory.tie->x, trajectory.tie->y, trajectory.tie->theta},
          std::move(nodes->nodes), SamplesOf(trajectory.session_id), {}});
    }
    if (map_nodes == 0) continue;
    for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
      if (trajectory.tie) continue;
      untied.insert(trajectory.session_id);
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (stop_) return false;
      }
      more = Turn(map.name, trajectory, tied, map_nodes) || more;
    }
  }
  more = FollowPass(&referenced) || more;
  // After the passes that take or renew the leases of the maps this server works on.
  if (sources_.publish && sources_.maps_to_publish && sources_.holds) {
    PublishPass(sources_.maps_to_publish());
  }
  // Sessions tied in, gone or detached meanwhile; stored nodes nobody reads any more.
  const auto erase_unless = [](auto& by_id, const std::set<std::string>& keep) {
    for (auto it = by_id.begin(); it != by_id.end();) {
      it = keep.count(it->first) ? std::next(it) : by_id.erase(it);
    }
  };
  erase_unless(joining_, untied);
  erase_unless(stored_, referenced);
  erase_unless(exhausted_, untied);
  return more;
}

bool MapTieWorker::Turn(const std::string& map, const storage::MapTrajectoryRecord& trajectory,
                        const std::vector<laser_slam::TiedTrajectory>& tied,
                        std::size_t map_nodes) {
  const std::string& session_id = trajectory.session_id;
  if (auto it = exhausted_.find(session_id); it != exhausted_.end()) {
    const bool grown = static_cast<double>(map_nodes) >
                       (1.0 + options_.tie.map_growth) * static_cast<double>(it->second);
    if (!grown && !Moving(trajectory)) return false;
    exhausted_.erase(it);
  }
  Joining& joining = joining_[session_id];
  if (joining.tie == nullptr || joining.map != map) {
    absl::StatusOr<std::unique_ptr<laser_slam::TrajectoryTie>> tie =
        laser_slam::TrajectoryTie::Create(options_.tie);
    if (!tie.ok()) {
      spdlog::error("SLAM map \"{}\": cannot search for session {}: {}", map, session_id,
                    tie.status().ToString());
      return false;
    }
    joining = Joining{map, *std::move(tie)};
  }
  absl::StatusOr<TrajectoryNodes> nodes = NodesOf(trajectory);
  if (!nodes.ok() || nodes->nodes.empty()) return false;
  if (joining.tie->WantsMap(map_nodes)) {
    if (absl::Status s = joining.tie->SetMap(laser_slam::MapCloud(tied, options_.tie.point_cell),
                                             map_nodes);
        !s.ok()) {
      spdlog::warn("SLAM map \"{}\": cannot search it for session {}: {}", map, session_id,
                   s.ToString());
      return false;
    }
  }
  // The engine spends what the session's scans granted (TieOptions::reads_per_scan), at most a
  // turn's worth now.
  const std::int64_t before = joining.tie->progress().reads;
  const int searches_before = joining.tie->progress().searches;
  const laser_slam::TieProgress& progress = joining.tie->Advance(nodes->nodes, kTurnReads);
  if (sources_.searched && progress.searches != searches_before) {
    sources_.searched(session_id, progress);
  }
  if (!progress.tie) {
    if (progress.reads > before) return true;  // more to do now
    if (!nodes->resident && trajectory.session_state == storage::SlamSessionState::kClosed &&
        progress.clock_scan >= static_cast<double>(nodes->nodes.back().scan)) {
      spdlog::info(
          "SLAM map \"{}\": session {} (closed) was searched for to its last scan and not found "
          "in the map ({} searches, {} unique matches, {} ambiguous, {} disagreeing pairs, {} "
          "agreeing pairs outvoted)",
          map, session_id, progress.searches, progress.matches, progress.ambiguous,
          progress.disagreements, progress.outvoted);
      exhausted_[session_id] = map_nodes;
      joining_.erase(session_id);
    }
    return false;  // waits for scans
  }
  if (options_.verify_ties) {
    // Checked on the robot's nodes up to the scan the tie came at, as a robot at its own pace
    // would be checked: the searches run on a clock of scans, and a replay faster than the
    // searches must not have its tie judged on more of its map (ACES split at 25 %, replayed
    // at 110x, had every right tie refused on the nodes of its whole slice).
    std::vector<laser_slam::NodeView> at_tie;
    for (const laser_slam::NodeView& node : nodes->nodes) {
      if (node.scan <= progress.tied_at_scan) at_tie.push_back(node);
    }
    std::string why;
    if (!laser_slam::TieKeepsTheMapConsistent(tied, at_tie, *progress.tie, &why)) {
      // A look-alike place the map does not hold yet: the robot's own scans elsewhere contradict
      // the map there. The search goes on.
      spdlog::info("SLAM map \"{}\": session {} found at ({:.3f}, {:.3f}, {:.4f}) but not tied "
                   "in: {}",
                   map, session_id, progress.tie->x, progress.tie->y, progress.tie->theta, why);
      joining.tie->Refuse();
      return true;
    }
  }
  const storage::MapTie tie{progress.tie->x, progress.tie->y, progress.tie->theta};
  if (absl::Status s = sources_.tie(map, session_id, tie); !s.ok()) {
    spdlog::warn("SLAM map \"{}\": session {} was found in it but not tied in: {}", map,
                 session_id, s.ToString());
  } else {
    const laser_slam::NodeView& first = nodes->nodes.front();
    // The robot's clock at the scan it was tied in at: the newest node's stamp at or before it.
    double tied_stamp = first.stamp;
    for (const laser_slam::NodeView& node : nodes->nodes) {
      if (node.scan <= progress.tied_at_scan) tied_stamp = node.stamp;
    }
    // What results.md measures: the time from the robot's first scan to its tie, in its scans
    // and its own clock (as at its own pace: the searches run on a clock of scans).
    spdlog::info(
        "SLAM map \"{}\": session {} tied in at ({:.3f}, {:.3f}, {:.4f}) at its scan {} ({:.1f} s "
        "after its first node, scan {}), matched at scan {}; {} searches, {} unique matches, {} "
        "ambiguous, {} disagreeing pairs, {:.0f} M cell reads, {} agreeing pairs outvoted before",
        map, session_id, tie.x, tie.y, tie.theta, progress.tied_at_scan,
        tied_stamp - first.stamp, first.scan, progress.tie_scan, progress.searches,
        progress.matches, progress.ambiguous, progress.disagreements, progress.reads / 1e6,
        progress.outvoted);
  }
  joining_.erase(session_id);
  return false;
}

std::vector<laser_slam::OriginSample> MapTieWorker::SamplesOf(
    const std::string& session_id) const {
  auto it = following_.find(session_id);
  if (it != following_.end() && it->second.follow != nullptr) return it->second.follow->samples();
  return sources_.samples ? sources_.samples(session_id) : std::vector<laser_slam::OriginSample>{};
}

bool MapTieWorker::FollowPass(std::set<std::string>* referenced) {
  if (!options_.follow || !sources_.maps_to_follow || !sources_.follow) return false;
  bool more = false;
  std::set<std::string> followed;
  for (const storage::MapRecord& map : sources_.maps_to_follow()) {
    if (!Owned(map.name)) continue;  // another server of the fleet follows its robots
    std::vector<const storage::MapTrajectoryRecord*> tied;
    for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
      if (trajectory.tie) tied.push_back(&trajectory);
    }
    // Every tied-in trajectory but the first (the map frame's) is followed; a closed one matched
    // to its last node is done, and its map's nodes are not read for it again.
    bool work = false;
    for (std::size_t i = 1; i < tied.size(); ++i) {
      const std::string& id = tied[i]->session_id;
      followed.insert(id);
      auto it = following_.find(id);
      if (it == following_.end() || !it->second.done || Moving(*tied[i])) work = true;
    }
    if (!work) continue;
    std::vector<laser_slam::TiedTrajectory> all;
    for (const storage::MapTrajectoryRecord* trajectory : tied) {
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (stop_) return false;
      }
      referenced->insert(trajectory->session_id);
      absl::StatusOr<TrajectoryNodes> nodes = NodesOf(*trajectory);
      all.push_back(laser_slam::TiedTrajectory{
          laser_slam::Pose2{trajectory->tie->x, trajectory->tie->y, trajectory->tie->theta},
          nodes.ok() ? std::move(nodes->nodes) : std::vector<laser_slam::NodeView>{},
          SamplesOf(trajectory->session_id),
          nodes.ok() ? std::move(nodes->loops) : std::vector<laser_slam::GraphConstraint>{}});
    }
    for (std::size_t i = 1; i < tied.size(); ++i) {
      more = FollowTurn(map.name, *tied[i], all, i) || more;
    }
  }
  for (auto it = following_.begin(); it != following_.end();) {
    it = followed.count(it->first) ? std::next(it) : following_.erase(it);
  }
  return more;
}

bool MapTieWorker::FollowTurn(const std::string& map,
                              const storage::MapTrajectoryRecord& trajectory,
                              const std::vector<laser_slam::TiedTrajectory>& all,
                              std::size_t self) {
  const std::string& session_id = trajectory.session_id;
  const std::vector<laser_slam::NodeView>& nodes = all[self].nodes;
  if (nodes.empty()) return false;
  Following& following = following_[session_id];
  if (following.follow == nullptr || following.map != map) {
    // From the follow stored with the map (by this server before a restart, or by the map's
    // previous owner), else from the origin stored at its tie, observed from its first node on.
    absl::StatusOr<std::unique_ptr<laser_slam::TrajectoryFollow>> follow =
        all[self].samples.empty()
            ? laser_slam::TrajectoryFollow::Create(
                  options_.follow_options,
                  laser_slam::OriginSample{nodes.front().scan, nodes.front().stamp,
                                           all[self].origin})
            : laser_slam::TrajectoryFollow::Resume(options_.follow_options, all[self].samples);
    if (!follow.ok()) {
      spdlog::error("SLAM map \"{}\": cannot follow session {}: {}", map, session_id,
                    follow.status().ToString());
      following_.erase(session_id);
      return false;
    }
    following = Following{map, *std::move(follow), false};
  }
  std::size_t others_nodes = 0;
  for (std::size_t j = 0; j < all.size(); ++j) {
    if (j != self) others_nodes += all[j].nodes.size();
  }
  if (following.follow->WantsMap(others_nodes)) {
    std::vector<laser_slam::TiedTrajectory> others;
    for (std::size_t j = 0; j < all.size(); ++j) {
      if (j != self) others.push_back(all[j]);
    }
    if (absl::Status s = following.follow->SetMap(
            laser_slam::MapCloud(others, options_.follow_options.point_cell), others_nodes,
            options_.follow_options.window_for_map_drift ||
                    options_.follow_options.window_from_uncertainty
                ? laser_slam::MapPath(others)
                : std::vector<laser_slam::MapPathPoint>{});
        !s.ok()) {
      spdlog::warn("SLAM map \"{}\": cannot follow session {}: {}", map, session_id,
                   s.ToString());
      return false;
    }
  }
  const std::size_t before = following.follow->samples().size();
  const int looked = following.follow->Advance(nodes, kFollowAttempts);
  if (following.follow->samples().size() != before) {
    if (absl::Status s = sources_.follow(map, session_id, following.follow->samples(),
                                         following.follow->progress());
        !s.ok()) {
      spdlog::warn("SLAM map \"{}\": session {}'s origin samples not kept: {}", map, session_id,
                   s.ToString());
    }
  }
  if (looked < kFollowAttempts && !Moving(trajectory) &&
      trajectory.session_state == storage::SlamSessionState::kClosed && !following.done) {
    following.done = true;
    const laser_slam::FollowProgress& p = following.follow->progress();
    // What results.md reads: how often a closed robot was matched again after its tie.
    spdlog::info(
        "SLAM map \"{}\": session {} (closed) followed to its last node: {} windowed matches, {} "
        "origin samples, {} weak, {} ambiguous, {} beyond their uncertainty, {:.0f} M cell reads",
        map, session_id, p.attempts, p.matched, p.weak, p.ambiguous, p.beyond, p.reads / 1e6);
  }
  return looked == kFollowAttempts;
}

}  // namespace waymark::service
