#ifndef WAYMARK_SERVER_SERVICE_IDLE_STREAM_REAPER_H_
#define WAYMARK_SERVER_SERVICE_IDLE_STREAM_REAPER_H_

// Ends client streams that have sent nothing for too long. With gRPC's synchronous server every
// open stream holds a request thread, and keepalive only notices peers that are gone, not a robot
// (or an attacker) that connects, opens streams and stays silent: without this, such streams pile
// up to the thread limit and starve every other robot. The per-robot cap (stream_limiter.h)
// bounds one token; this bounds time.

#include <grpcpp/server_context.h>

#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

namespace waymark::service {

class IdleStreamReaper {
 public:
  // Held by a stream handler while it runs; Touch() after every message received.
  class Watch {
   public:
    ~Watch();
    Watch(const Watch&) = delete;
    Watch& operator=(const Watch&) = delete;
    void Touch();
    // True once the reaper cancelled the call (the handler's Read then fails).
    bool reaped() const;

   private:
    friend class IdleStreamReaper;
    Watch(IdleStreamReaper* reaper, grpc::ServerContextBase* context)
        : reaper_(reaper), context_(context) {}
    IdleStreamReaper* reaper_;
    grpc::ServerContextBase* context_;
  };

  // `idle_seconds` <= 0 turns it off (Watch() then returns watches that do nothing).
  explicit IdleStreamReaper(double idle_seconds);
  ~IdleStreamReaper();
  IdleStreamReaper(const IdleStreamReaper&) = delete;
  IdleStreamReaper& operator=(const IdleStreamReaper&) = delete;

  std::unique_ptr<Watch> WatchStream(grpc::ServerContextBase* context);
  double idle_seconds() const { return idle_seconds_; }

 private:
  using Clock = std::chrono::steady_clock;
  struct Entry {
    Clock::time_point last_activity;
    bool reaped = false;
  };
  void Loop();

  const double idle_seconds_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::map<const Watch*, Entry> watched_;
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_IDLE_STREAM_REAPER_H_
