#include "server/service/auth/call_identity.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <mutex>
#include <unordered_map>
#include <utility>

namespace waymark::service {
namespace {

struct Table {
  std::mutex mutex;
  std::unordered_map<const grpc::ServerContextBase*, std::string> robot_ids;
  std::atomic<bool> warned_full{false};
};

// Never destroyed: calls may still end while static destructors run at exit.
Table& GetTable() {
  static Table* table = new Table;
  return *table;
}

}  // namespace

void SetCallRobotId(const grpc::ServerContextBase* context, std::string robot_id) {
  if (context == nullptr) return;
  Table& table = GetTable();
  std::lock_guard<std::mutex> lock(table.mutex);
  auto it = table.robot_ids.find(context);
  if (it != table.robot_ids.end()) {
    it->second = std::move(robot_id);
    return;
  }
  if (table.robot_ids.size() >= kMaxCallIdentities) {
    if (!table.warned_full.exchange(true)) {
      spdlog::warn(
          "call identity table full ({} calls): robot ids are not logged; is the call "
          "interceptor installed?",
          kMaxCallIdentities);
    }
    return;
  }
  table.robot_ids.emplace(context, std::move(robot_id));
}

std::string TakeCallRobotId(const grpc::ServerContextBase* context) {
  Table& table = GetTable();
  std::lock_guard<std::mutex> lock(table.mutex);
  auto node = table.robot_ids.extract(context);
  return node.empty() ? std::string() : std::move(node.mapped());
}

}  // namespace waymark::service
