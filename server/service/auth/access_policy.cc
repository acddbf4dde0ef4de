#include "server/service/auth/access_policy.h"

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"

namespace waymark::service {

using storage::TokenRole;

const char* ActionName(Action action) {
  switch (action) {
    case Action::kReadCrossings:
      return "read crossing databases";
    case Action::kRecognize:
      return "recognize crossings";
    case Action::kEditCrossings:
      return "edit crossing databases";
    case Action::kDeleteDatabase:
      return "delete crossing databases";
    case Action::kSlam:
      return "run SLAM sessions";
    case Action::kManageTokens:
      return "manage tokens";
    case Action::kWatchSlam:
      return "read SLAM sessions";
    case Action::kLiveView:
      return "watch the live view";
    case Action::kReadMaps:
      return "read maps";
    case Action::kEditMaps:
      return "create and delete maps";
  }
  return "do this";
}

std::string Caller::Describe() const {
  if (auth_off) return "(auth off)";
  return absl::StrCat("token ", QuoteClientText(token_name), " (", storage::TokenRoleName(role),
                      ", robot ", QuoteClientText(robot_id), ")");
}

TokenRole MinimumRole(Action action) {
  switch (action) {
    case Action::kWatchSlam:
    case Action::kLiveView:
    case Action::kReadMaps:
      return TokenRole::kViewer;
    case Action::kReadCrossings:
    case Action::kRecognize:
    case Action::kSlam:
      return TokenRole::kRobot;
    case Action::kEditCrossings:
    case Action::kEditMaps:
      return TokenRole::kMapper;
    case Action::kDeleteDatabase:
    case Action::kManageTokens:
      return TokenRole::kAdmin;
  }
  return TokenRole::kAdmin;
}

namespace {

// Roles are nested: each one may do everything the one before it may.
// The viewer, added last, ranks first: it may only watch.
int Rank(TokenRole role) {
  switch (role) {
    case TokenRole::kViewer:
      return 0;
    case TokenRole::kRobot:
      return 1;
    case TokenRole::kMapper:
      return 2;
    case TokenRole::kAdmin:
      return 3;
  }
  return 0;
}

}  // namespace

absl::Status CheckAction(const Caller& caller, Action action) {
  if (caller.auth_off) return absl::OkStatus();
  const TokenRole needed = MinimumRole(action);
  if (action == Action::kLiveView) {
    if (caller.role == TokenRole::kViewer || caller.role == TokenRole::kAdmin) {
      return absl::OkStatus();
    }
    return absl::PermissionDeniedError(absl::StrCat(
        caller.Describe(), " may not ", ActionName(action),
        ": that needs a viewer (or admin) token; robot and mapper tokens speak for one robot"));
  }
  if (Rank(caller.role) >= Rank(needed)) return absl::OkStatus();
  return absl::PermissionDeniedError(absl::StrCat(caller.Describe(), " may not ",
                                                  ActionName(action), ": that needs role ",
                                                  storage::TokenRoleName(needed)));
}

bool SeesAllRobots(const Caller& caller) {
  return caller.auth_off || caller.role == TokenRole::kAdmin || caller.role == TokenRole::kViewer;
}

absl::Status CheckRobot(const Caller& caller, const std::string& robot_id) {
  if (SeesAllRobots(caller) || caller.robot_id == robot_id) {
    return absl::OkStatus();
  }
  return absl::PermissionDeniedError(absl::StrCat(caller.Describe(),
                                                  " may not use the SLAM sessions of robot \"",
                                                  robot_id, "\""));
}

}  // namespace waymark::service
