#ifndef WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_FLEET_SYNC_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_FLEET_SYNC_H_

// Keeps a server's crossing databases in step with the other servers of a shared database
// (PostgreSQL, docs/scale-out.md). One thread listens to the store's change feed and runs
// CrossingRegistry::Sync whenever another server wrote, so an enrollment on one server is
// recognized on the others within milliseconds; it also syncs every `period_ms` in any case,
// because notifications sent while the listening connection was down are lost.

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "server/service/crossing/crossing_registry.h"
#include "server/service/crossing/folder.h"

namespace waymark::service {

class CrossingFleetSync {
 public:
  struct Options {
    int period_ms = 5000;  // the catch-up without a notification
    int poll_ms = 200;     // how soon a stop is noticed
  };

  // nullptr when the registry's store is not shared (nothing to follow).
  static std::unique_ptr<CrossingFleetSync> Start(CrossingRegistry* registry, Options options);
  static std::unique_ptr<CrossingFleetSync> Start(CrossingRegistry* registry) {
    return Start(registry, Options());
  }
  ~CrossingFleetSync();  // stops and joins (within poll_ms)
  CrossingFleetSync(const CrossingFleetSync&) = delete;
  CrossingFleetSync& operator=(const CrossingFleetSync&) = delete;

  // Syncs run so far (for tests and metrics).
  int syncs() const { return syncs_.load(); }

 private:
  CrossingFleetSync(CrossingRegistry* registry, Options options);
  void Loop();

  CrossingRegistry* const registry_;
  const Options options_;
  std::atomic<bool> stopping_{false};
  std::atomic<int> syncs_{0};
  std::string last_error_;  // logged once until it changes
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_CROSSING_FLEET_SYNC_H_
