#ifndef WAYMARK_SERVER_SERVICE_AUTH_ACCESS_POLICY_H_
#define WAYMARK_SERVER_SERVICE_AUTH_ACCESS_POLICY_H_

// Who may do what (issue 6): the one table from token roles to the service's actions, and the
// rule that a robot sees only its own SLAM sessions. Plain C++: the gRPC layer (authenticator.h)
// turns a request's token into a Caller and asks here.

#include <string>

#include "absl/status/status.h"
#include "server/service/auth/folder.h"
#include "storage/token_store.h"

namespace waymark::service {

// What a call does, coarser than the RPCs: every RPC maps to exactly one action.
enum class Action {
  kReadCrossings,    // ListDatabases, GetDatabaseStats, ListCrossings
  kRecognize,        // RecognizeCrossing, StreamRecognize
  kEditCrossings,    // CreateDatabase, AddCrossing, DeleteCrossing, EnrollView, BulkEnroll,
                     // StreamEnroll, RebuildClusters
  kDeleteDatabase,   // DeleteDatabase: drops every robot's views at once, so admin only
  kWatchSlam,        // reading SLAM sessions: ListSessions, GetSession, GetMap, GetTrajectory,
                     // GetOccupancyGrid (a robot reads its own sessions, a viewer every robot's)
  kSlam,             // every other SlamService RPC, DeleteSession included (further limited to
                     // the caller's own sessions, like CloseSession)
  kManageTokens,     // TokenService
  kLiveView,         // the live view (waymark-server --live): every robot's sessions as they run
  kReadMaps,         // maps shared by robots: ListMaps, GetMapInfo, GetMapOccupancyGrid (every
                     // robot's trajectories in them; a robot joins one with CreateSession, kSlam)
  kEditMaps,         // CreateMap, DeleteMap
};

// "recognize", "edit crossing databases", ... for error messages.
const char* ActionName(Action action);

// The authenticated identity of a call.
struct Caller {
  std::string token_name;  // "" when auth is off (--insecure-dev)
  std::string robot_id;    // the robot the token speaks for; "" when auth is off
  storage::TokenRole role = storage::TokenRole::kRobot;
  bool auth_off = false;   // --insecure-dev: everything allowed, any robot id accepted

  // The caller as written in logs and errors: token name and robot.
  std::string Describe() const;
};

// The smallest role allowed to do `action`. Roles rank viewer < robot < mapper < admin, and each
// may do what the ones below it may, with one exception: the live view (kLiveView) is for viewer
// and admin tokens only. It shows every robot's sessions, while a robot's or mapper's token speaks
// for one robot (a token taken from a robot must not show the whole fleet).
storage::TokenRole MinimumRole(Action action);

// OK when the caller's role allows the action; PERMISSION_DENIED naming the action, the caller's
// role and the role needed otherwise.
absl::Status CheckAction(const Caller& caller, Action action);

// Admins, viewers and auth off see every robot's sessions; robot and mapper tokens only their own.
// A viewer's view is read-only: every action that changes a session needs a robot's role, checked
// before the robot.
bool SeesAllRobots(const Caller& caller);

// OK when the caller may see or feed data of robot `robot_id` (its own, or any when admin or auth
// off); PERMISSION_DENIED otherwise, naming both robots.
absl::Status CheckRobot(const Caller& caller, const std::string& robot_id);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_AUTH_ACCESS_POLICY_H_
