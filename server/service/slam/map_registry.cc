#include "server/service/slam/map_registry.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <set>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/laser_slam/geometry.h"
#include "server/service/slam/map_follow_codec.h"
#include "server/service/slam/slam_params.h"
#include "storage/map_records.h"

namespace waymark::service {
namespace {

v1::Map ToProto(const storage::MapRecord& record) {
  v1::Map map;
  map.set_name(record.name);
  map.set_created_at_unix(static_cast<int64_t>(record.created_at));
  map.set_updated_at_unix(static_cast<int64_t>(record.updated_at));
  map.set_revision(static_cast<uint64_t>(record.revision));
  for (const storage::MapTrajectoryRecord& t : record.trajectories) {
    v1::MapTrajectory* trajectory = map.add_trajectories();
    trajectory->set_session_id(t.session_id);
    trajectory->set_robot_id(t.robot_id);
    trajectory->set_state(t.session_state == storage::SlamSessionState::kOpen
                              ? v1::Session::OPEN
                              : v1::Session::CLOSED);
    trajectory->set_joined_at_unix(static_cast<int64_t>(t.joined_at));
    trajectory->set_tied_in(t.tie.has_value());
    if (t.tie.has_value()) {
      trajectory->mutable_origin()->set_x(t.tie->x);
      trajectory->mutable_origin()->set_y(t.tie->y);
      trajectory->mutable_origin()->set_theta(t.tie->theta);
    }
    trajectory->set_scans_processed(static_cast<uint64_t>(t.scans_processed));
  }
  if (!record.lease.owner.empty()) map.set_owner(record.lease.address);
  return map;
}

}  // namespace

v1::Pose2D InMapFrame(const storage::MapTie& tie, const v1::Pose2D& pose) {
  const double c = std::cos(tie.theta);
  const double s = std::sin(tie.theta);
  v1::Pose2D out;
  out.set_x(tie.x + c * pose.x() - s * pose.y());
  out.set_y(tie.y + s * pose.x() + c * pose.y());
  out.set_theta(std::remainder(tie.theta + pose.theta(), 2 * M_PI));
  return out;
}

// ---------------------------------------------------------------------------------------------
// MapMembership

void MapMembership::Decorate(v1::SlamUpdate* update) const {
  if (update->has_rejection() || !update->has_pose()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (map_.empty()) return;
  v1::MapPose* map_pose = update->mutable_map_pose();
  map_pose->set_map(map_);
  map_pose->set_map_revision(static_cast<uint64_t>(revision_));
  map_pose->set_tied_in(tie_.has_value());
  if (tie_.has_value()) *map_pose->mutable_pose() = InMapFrame(*tie_, update->pose());
}

void MapMembership::Set(std::optional<storage::MapTie> tie, int64_t revision) {
  std::lock_guard<std::mutex> lock(mutex_);
  tie_ = tie;
  revision_ = revision;
}

void MapMembership::Detach() {
  std::lock_guard<std::mutex> lock(mutex_);
  map_.clear();
}

std::string MapMembership::map() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return map_;
}

std::optional<storage::MapTie> MapMembership::tie() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return map_.empty() ? std::nullopt : tie_;
}

bool MapMembership::tied_in() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tie_.has_value();
}

// ---------------------------------------------------------------------------------------------
// MapRegistry

absl::Status MapRegistry::CheckStore() const {
  if (store_ == nullptr) {
    return absl::FailedPreconditionError("this server keeps no maps (it has no map store)");
  }
  return absl::OkStatus();
}

void MapRegistry::Remember(const storage::MapRecord& map) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
    std::shared_ptr<MapMembership>& member = members_[trajectory.session_id];
    if (member == nullptr || member->map() != map.name) {
      member = std::make_shared<MapMembership>(map.name);
    }
    member->Set(trajectory.tie, map.revision);
    // The follow as the map's owner stored it, unless this server follows the robot itself (its
    // own samples are newer than the store's).
    auto followed = followed_.find(trajectory.session_id);
    if (followed != followed_.end() && (followed->second.here ||
                                        followed->second.revision >= map.revision)) {
      continue;
    }
    if (trajectory.follow.empty() || !trajectory.tie.has_value()) {
      if (followed != followed_.end()) followed_.erase(followed);
      continue;
    }
    absl::StatusOr<StoredFollow> stored = DecodeFollow(trajectory.follow);
    if (stored.ok() && stored->samples.empty()) {
      // Tied in and not followed yet: only how the searches went.
      Followed& entry = followed_[trajectory.session_id];
      entry = Followed{};
      entry.search = stored->search;
      entry.revision = map.revision;
      continue;
    }
    if (!stored.ok()) {
      // The stored origin still holds for every pose; the follow starts again from it.
      spdlog::warn("SLAM map \"{}\": session {}'s stored follow is unreadable ({}); its origin "
                   "holds for every pose",
                   map.name, trajectory.session_id, stored.status().ToString());
      if (followed != followed_.end()) followed_.erase(followed);
      continue;
    }
    Followed& entry = followed_[trajectory.session_id];
    entry.stored = stored->samples.back().origin;
    entry.stored_count = stored->samples.size();
    entry.samples = std::move(stored->samples);
    entry.stats = stored->stats;
    entry.search = stored->search;
    entry.here = false;
    entry.revision = map.revision;
  }
}

absl::Status MapRegistry::Load() {
  if (store_ == nullptr) return absl::OkStatus();
  absl::StatusOr<std::vector<storage::MapRecord>> maps = store_->ListMaps();
  if (!maps.ok()) return maps.status();
  size_t trajectories = 0;
  for (const storage::MapRecord& map : *maps) {
    Remember(map);
    trajectories += map.trajectories.size();
  }
  if (!maps->empty()) {
    spdlog::info("SLAM maps: {} loaded with {} trajectories", maps->size(), trajectories);
  }
  return absl::OkStatus();
}

absl::StatusOr<v1::Map> MapRegistry::CreateMap(const std::string& name) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  absl::StatusOr<storage::MapRecord> created = store_->CreateMap(name);
  if (!created.ok()) return created.status();
  spdlog::info("SLAM map \"{}\" created", name);
  return ToProto(*created);
}

absl::StatusOr<v1::Map> MapRegistry::GetMap(const std::string& name) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  absl::StatusOr<storage::MapRecord> map = store_->GetMap(name);
  if (!map.ok()) return map.status();
  v1::Map out = ToProto(*map);
  AddSamples(*map, &out);
  return out;
}

std::vector<laser_slam::OriginSample> MapRegistry::FollowedSamples(
    const std::string& session_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = followed_.find(session_id);
  return it == followed_.end() ? std::vector<laser_slam::OriginSample>{} : it->second.samples;
}

void MapRegistry::AddSamples(const storage::MapRecord& record, v1::Map* map) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < map->trajectories_size(); ++i) {
    v1::MapTrajectory& trajectory = *map->mutable_trajectories(i);
    if (!trajectory.tied_in()) {
      if (auto it = searches_.find(trajectory.session_id()); it != searches_.end()) {
        *trajectory.mutable_search() = it->second;
      }
    } else if (auto it = followed_.find(trajectory.session_id());
               it != followed_.end() && it->second.here) {
      // This server's own follow is newer than the store's.
      for (const laser_slam::OriginSample& sample : it->second.samples) {
        SetSample(sample, trajectory.add_origin_samples());
      }
      *trajectory.mutable_follow() = it->second.stats;
      *trajectory.mutable_search() = it->second.search;
    } else if (const std::string& stored = record.trajectories[static_cast<size_t>(i)].follow;
               !stored.empty()) {
      // The store's, written by the map's owner (maybe another server). Unreadable bytes (logged
      // where the registry reads them, Remember) show no samples: the stored origin then holds
      // for every pose.
      if (absl::StatusOr<StoredFollow> follow = DecodeFollow(stored); follow.ok()) {
        for (const laser_slam::OriginSample& sample : follow->samples) {
          SetSample(sample, trajectory.add_origin_samples());
        }
        *trajectory.mutable_follow() = follow->stats;
        *trajectory.mutable_search() = follow->search;
      }
    }
    trajectory.set_warning(MapTrajectoryWarning(trajectory));
  }
}

absl::StatusOr<v1::ListMapsResponse> MapRegistry::ListMaps() {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  absl::StatusOr<std::vector<storage::MapRecord>> maps = store_->ListMaps();
  if (!maps.ok()) return maps.status();
  v1::ListMapsResponse response;
  for (const storage::MapRecord& map : *maps) {
    *response.add_maps() = ToProto(map);
    AddSamples(map, &response.mutable_maps()->at(response.maps_size() - 1));
  }
  return response;
}

absl::StatusOr<v1::DeleteMapResponse> MapRegistry::DeleteMap(const std::string& name, bool force) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  absl::StatusOr<storage::MapRecord> map = store_->GetMap(name);
  if (!map.ok()) return map.status();
  std::vector<std::string> open;
  for (const storage::MapTrajectoryRecord& trajectory : map->trajectories) {
    if (trajectory.session_state == storage::SlamSessionState::kOpen) {
      open.push_back(trajectory.session_id);
    }
  }
  if (!open.empty() && !force) {
    return absl::FailedPreconditionError(absl::StrCat(
        "map \"", name, "\" is in use: ", open.size(), " open session", open.size() == 1 ? "" : "s",
        " (", open.front(), open.size() > 1 ? ", ..." : "",
        ") joined it; close them first, or delete the map with force, which detaches them (they "
        "go on alone)"));
  }
  absl::StatusOr<storage::MapRecord> deleted = store_->DeleteMap(name);
  if (!deleted.ok()) return deleted.status();
  uint32_t detached = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const storage::MapTrajectoryRecord& trajectory : deleted->trajectories) {
      auto it = members_.find(trajectory.session_id);
      if (it == members_.end()) continue;
      it->second->Detach();
      members_.erase(it);
    }
  }
  for (const storage::MapTrajectoryRecord& trajectory : deleted->trajectories) {
    if (trajectory.session_state == storage::SlamSessionState::kOpen) ++detached;
  }
  spdlog::info("SLAM map \"{}\" deleted ({} trajectories, {} open sessions detached)", name,
               deleted->trajectories.size(), detached);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    graphs_.erase(name);
  }
  v1::DeleteMapResponse response;
  *response.mutable_map() = ToProto(*deleted);
  response.set_detached_sessions(detached);
  return response;
}

absl::Status MapRegistry::CheckJoin(const v1::CreateSessionRequest& request) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  if (request.has_visual()) {
    return absl::InvalidArgumentError(
        "a visual session cannot join a map: maps are built by laser sessions");
  }
  if (request.laser().has_localize()) {
    return absl::InvalidArgumentError(
        "a localization session cannot join a map: it does not change its map; join the map "
        "with a mapping session instead");
  }
  if (request.laser().params().has_loop_closure() && !request.laser().params().loop_closure()) {
    return absl::InvalidArgumentError(
        "a session without the loop-closing back end (params.loop_closure = false) cannot join a "
        "map: a map's trajectories are its scan nodes");
  }
  if (absl::Status s = storage::CheckMapName(request.map()); !s.ok()) return s;
  return store_->GetMap(request.map()).status();
}

absl::StatusOr<v1::Map> MapRegistry::Join(const std::string& name, const std::string& session_id) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  absl::StatusOr<storage::MapRecord> joined = store_->AddTrajectory(name, session_id);
  if (!joined.ok()) return joined.status();
  Remember(*joined);
  const bool tied = !joined->trajectories.empty() && joined->trajectories.back().tie.has_value();
  spdlog::info("SLAM session {} joined map \"{}\" as trajectory {} ({})", session_id, name,
               joined->trajectories.size(),
               tied ? "it defines the map frame" : "not yet in the map");
  return ToProto(*joined);
}

void MapRegistry::SessionDeleted(const std::string& session_id) {
  if (store_ == nullptr) return;
  std::string map;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = members_.find(session_id);
    if (it == members_.end()) return;
    map = it->second->map();
    it->second->Detach();
    members_.erase(it);
    followed_.erase(session_id);
    searches_.erase(session_id);
  }
  if (map.empty()) return;
  absl::StatusOr<storage::MapRecord> left = store_->RemoveTrajectory(map, session_id);
  if (!left.ok()) {
    // The session's row is gone with its trajectory row; only the revision and the frame's anchor
    // are behind, and the next change of the map puts them right.
    spdlog::warn("SLAM map \"{}\": session {} deleted, but the map was not updated: {}", map,
                 session_id, left.status().ToString());
    return;
  }
  Remember(*left);
}

std::shared_ptr<MapMembership> MapRegistry::Membership(const std::string& session_id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = members_.find(session_id);
    if (it != members_.end()) return it->second;
  }
  if (!fleet() || store_ == nullptr) return nullptr;
  // Joined on another server of the fleet since this one loaded its maps.
  absl::StatusOr<std::vector<storage::MapRecord>> maps = store_->ListMaps();
  if (!maps.ok()) {
    spdlog::warn("SLAM maps: cannot look session {} up: {}", session_id, maps.status().ToString());
    return nullptr;
  }
  for (const storage::MapRecord& map : *maps) {
    for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
      if (trajectory.session_id == session_id) Remember(map);
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = members_.find(session_id);
  return it == members_.end() ? nullptr : it->second;
}

std::string MapRegistry::MapOf(const std::string& session_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = members_.find(session_id);
  return it == members_.end() ? std::string() : it->second->map();
}

std::vector<std::pair<std::string, storage::MapTie>> MapRegistry::TiedMembers(
    const std::string& map) const {
  std::vector<std::pair<std::string, storage::MapTie>> out;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [session_id, member] : members_) {
    if (member->map() != map) continue;
    if (std::optional<storage::MapTie> tie = member->tie()) out.emplace_back(session_id, *tie);
  }
  return out;
}

std::vector<storage::MapRecord> MapRegistry::StoredMapsOf(
    const std::function<bool(const MapMembership&)>& member,
    const std::function<bool(const storage::MapRecord&)>& keep) {
  if (store_ == nullptr) return {};
  std::set<std::string> names;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [session_id, membership] : members_) {
      if (member(*membership)) {
        if (std::string map = membership->map(); !map.empty()) names.insert(std::move(map));
      }
    }
  }
  std::vector<storage::MapRecord> maps;
  for (const std::string& name : names) {
    absl::StatusOr<storage::MapRecord> map = store_->GetMap(name);
    if (!map.ok()) continue;  // deleted meanwhile, or the store is down: the next pass asks again
    // Another server of the fleet may have tied one in, moved origins or stored follows.
    Remember(*map);
    if (keep(*map)) maps.push_back(*std::move(map));
  }
  return maps;
}

namespace {
int TiedIn(const storage::MapRecord& map) {
  int tied = 0;
  for (const storage::MapTrajectoryRecord& trajectory : map.trajectories) {
    tied += trajectory.tie.has_value() ? 1 : 0;
  }
  return tied;
}
}  // namespace

std::vector<storage::MapRecord> MapRegistry::MapsToTie() {
  return StoredMapsOf([](const MapMembership& m) { return !m.tied_in(); },
                      [](const storage::MapRecord& map) {
                        const int tied = TiedIn(map);
                        return tied > 0 && tied < static_cast<int>(map.trajectories.size());
                      });
}

absl::Status MapRegistry::Tie(const std::string& map, const std::string& session_id,
                              const storage::MapTie& tie) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  // A tie found again starts a new follow: the old samples go. The searches that found it are
  // kept with it (a tie among look-alike places stays marked after it).
  StoredFollow searched;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = searches_.find(session_id); it != searches_.end()) searched.search = it->second;
  }
  absl::StatusOr<storage::MapRecord> tied = store_->TieTrajectory(
      map, session_id, tie, searched.search.tried() > 0 ? EncodeFollow(searched) : "");
  if (!tied.ok()) return tied.status();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    followed_.erase(session_id);
    searches_.erase(session_id);
  }
  Remember(*tied);
  return absl::OkStatus();
}

std::vector<storage::MapRecord> MapRegistry::MapsToFollow() {
  return StoredMapsOf([](const MapMembership& m) { return m.tied_in(); },
                      [](const storage::MapRecord& map) { return TiedIn(map) >= 2; });
}

std::vector<storage::MapRecord> MapRegistry::MapsWithOthers() {
  return StoredMapsOf([](const MapMembership&) { return true; },
                      [](const storage::MapRecord& map) { return map.trajectories.size() >= 2; });
}

void MapRegistry::Searched(const std::string& session_id,
                           const laser_slam::TieProgress& progress) {
  std::lock_guard<std::mutex> lock(mutex_);
  searches_[session_id] = StatsOf(progress);
}

absl::Status MapRegistry::Follow(const std::string& map, const std::string& session_id,
                                 const std::vector<laser_slam::OriginSample>& samples,
                                 const laser_slam::FollowProgress& progress) {
  if (absl::Status s = CheckStore(); !s.ok()) return s;
  if (samples.empty()) return absl::InvalidArgumentError("no origin samples");
  // The store's origin is the latest, written with the samples at the first follow, and again
  // when it moved by more than this, or when this many samples were added since (the next owner,
  // or this server after a restart, goes on from what was stored).
  constexpr double kStoreXy = 0.05, kStoreTheta = 0.01;
  constexpr std::size_t kStoreSamples = 10;
  const laser_slam::Pose2 latest = samples.back().origin;
  bool store = false;
  std::string follow;  // what is stored, encoded under the lock
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto member = members_.find(session_id);
    if (member == members_.end() || member->second->map() != map) {
      return absl::NotFoundError(absl::StrCat("session ", session_id, " is not in map \"", map,
                                              "\" here"));
    }
    Followed& followed = followed_[session_id];
    if (followed.samples.empty()) followed.stored = samples.front().origin;
    // A follow resumed here counts on from what the stored one had counted.
    if (!followed.here) followed.base = followed.stats;
    followed.samples = samples;
    followed.here = true;
    followed.stats = Sum(followed.base, StatsOf(progress));
    store = std::hypot(latest.x - followed.stored.x, latest.y - followed.stored.y) > kStoreXy ||
            std::abs(std::remainder(latest.theta - followed.stored.theta, 2 * M_PI)) > kStoreTheta ||
            samples.size() >= followed.stored_count + kStoreSamples || followed.stored_count == 0;
    if (store) {
      followed.stored = latest;
      followed.stored_count = samples.size();
      follow = EncodeFollow(StoredFollow{samples, followed.stats, followed.search});
    }
  }
  if (!store) return absl::OkStatus();
  absl::StatusOr<storage::MapRecord> tied = store_->TieTrajectory(
      map, session_id, storage::MapTie{latest.x, latest.y, latest.theta}, follow);
  if (!tied.ok()) return tied.status();
  Remember(*tied);  // its answers carry the latest origin
  return absl::OkStatus();
}

bool MapRegistry::Holds(const std::string& map) const {
  if (!fleet() || store_ == nullptr) return true;
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = owned_.find(map);
  // owned_ holds when to renew it, a third of the ttl after it was taken: the lease itself runs
  // for two thirds more.
  return it != owned_.end() && SteadySeconds() < it->second + 2.0 * leases_->ttl_seconds() / 3.0;
}

bool MapRegistry::Own(const std::string& map) {
  if (!fleet() || store_ == nullptr) return true;
  const double now = SteadySeconds();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = owned_.find(map);
    if (it != owned_.end() && now < it->second) return true;
  }
  absl::StatusOr<storage::SlamLease> lease =
      store_->AcquireMapLease(map, leases_->owner(), leases_->address(), leases_->ttl_seconds());
  const bool own = lease.ok() && lease->owner == leases_->owner();
  std::lock_guard<std::mutex> lock(mutex_);
  const bool owned = owned_.count(map) > 0;
  if (own) {
    // Renewed every third of the ttl: the lease survives two missed renewals.
    owned_[map] = now + leases_->ttl_seconds() / 3.0;
    if (!owned) spdlog::info("SLAM map \"{}\": this server now ties and follows its robots", map);
    return true;
  }
  if (owned) {
    owned_.erase(map);
    spdlog::warn("SLAM map \"{}\": no longer tied and followed here ({})", map,
                 lease.ok() ? absl::StrCat("server ", lease->address, " holds its lease")
                            : lease.status().ToString());
    // Its samples come from the store again, as the new owner writes them.
    for (auto& [session_id, followed] : followed_) {
      auto member = members_.find(session_id);
      if (member != members_.end() && member->second->map() == map) {
        followed.here = false;
        followed.revision = -1;
      }
    }
  }
  return false;
}

void MapRegistry::ReleaseLeases() {
  if (!fleet() || store_ == nullptr) return;
  std::map<std::string, double> owned;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    owned.swap(owned_);
  }
  for (const auto& [map, renew_at] : owned) {
    if (absl::Status s = store_->ReleaseMapLease(map, leases_->owner()); !s.ok()) {
      spdlog::warn("SLAM map \"{}\": its lease was not given up ({}); it expires", map,
                   s.ToString());
    }
  }
}

}  // namespace waymark::service
