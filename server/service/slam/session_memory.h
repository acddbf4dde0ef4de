#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_MEMORY_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_MEMORY_H_

// Where the SLAM sessions of one registry are built, so that whoever cares is told when one leaves
// memory: the moment its last owner lets go (the session table, a stream still ending, a worker,
// a reader that rebuilt a closed session to answer GetMap), its engine destroyed with it.
//
// A session's engine is most of a server's memory (issue 38: about 2.4 KB per scan with loop
// closure on). Freeing it is not enough: glibc keeps what was freed in its arenas, and the server's
// memory trimmer only trimmed after growth, so closing 20 robots' sessions gave back 23 of 196 MB.
// The observers here are how the rest learn a session is gone and its engine freed: the trimmer
// returns the heap to the system (server/main.cc), the metrics and the live view drop what they
// kept for it.
//
// Header-only: its one job is the deleter below.

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "server/service/slam/folder.h"
#include "server/service/slam/slam_session.h"
#include "server/service/slam/slam_stream.h"

namespace waymark::service {

class SessionMemory {
 public:
  SessionMemory() : state_(std::make_shared<State>()) {}
  SessionMemory(const SessionMemory&) = delete;
  SessionMemory& operator=(const SessionMemory&) = delete;

  // A new, empty session with `id`. When it is destroyed (its engine with it), every observer is
  // called with its id, on the thread that dropped it, without the session table's lock
  // (SessionTable destroys sessions after unlocking). Sessions may outlive this object: the
  // observers live as long as the last of them.
  std::shared_ptr<SlamSession> NewSession(const std::string& id) {
    std::shared_ptr<State> state = state_;
    auto* raw = new SlamSession;
    raw->id = id;
    return std::shared_ptr<SlamSession>(raw, [state](SlamSession* session) {
      const std::string gone = session->id;
      delete session;
      state->Released(gone);
    });
  }

  // `id` is the caller's (SessionStreams uses its observer ids). Must return quickly and must not
  // call into the registry: it may run while a session is being closed.
  void AddObserver(uint64_t id, SlamReleasedObserver observer) {
    std::lock_guard<std::mutex> lock(state_->mu);
    auto list = std::make_shared<ObserverList>(*state_->observers);
    list->emplace_back(id, std::make_shared<const SlamReleasedObserver>(std::move(observer)));
    state_->observers = std::move(list);
  }
  void RemoveObserver(uint64_t id) {
    std::lock_guard<std::mutex> lock(state_->mu);
    auto list = std::make_shared<ObserverList>();
    for (const auto& entry : *state_->observers) {
      if (entry.first != id) list->push_back(entry);
    }
    state_->observers = std::move(list);
  }

 private:
  using ObserverList =
      std::vector<std::pair<uint64_t, std::shared_ptr<const SlamReleasedObserver>>>;
  struct State {
    std::mutex mu;  // guards observers (copied out, called unlocked)
    std::shared_ptr<const ObserverList> observers = std::make_shared<const ObserverList>();

    void Released(const std::string& id) {
      std::shared_ptr<const ObserverList> watching;
      {
        std::lock_guard<std::mutex> lock(mu);
        watching = observers;
      }
      for (const auto& [observer_id, observer] : *watching) (*observer)(id);
    }
  };

  std::shared_ptr<State> state_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_MEMORY_H_
