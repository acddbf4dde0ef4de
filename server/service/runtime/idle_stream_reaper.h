#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_IDLE_STREAM_REAPER_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_IDLE_STREAM_REAPER_H_

// Ends client streams that have sent nothing for too long. With gRPC's synchronous server every
// open stream holds a request thread, and keepalive only notices peers that are gone, not a robot
// (or an attacker) that connects, opens streams and stays silent: without this, such streams pile
// up to the thread limit and starve every other robot. The per-robot cap (stream_limiter.h)
// bounds one token; this bounds time.
//
// It also ends every open stream at shutdown (EndAll): a robot's stream lasts as long as the robot
// drives, and gRPC's shutdown would otherwise wait its whole grace for streams that never end on
// their own.
//
// And it ends streams whose caller is no longer allowed: every `revalidate_seconds` it asks each
// stream's revalidation (the authenticator's check of the call's token, authenticator.h) and
// ends a stream that answers UNAUTHENTICATED (its token revoked or expired since the stream
// opened) with that status. Without this, a token revoked mid-stream kept its open streams.

#include <grpcpp/server_context.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <functional>

#include "absl/status/status.h"
#include "server/service/runtime/folder.h"

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

  // `idle_seconds` <= 0 turns the idle limit off (streams are still watched for EndAll);
  // `revalidate_seconds` <= 0 turns revalidation off.
  explicit IdleStreamReaper(double idle_seconds, double revalidate_seconds = 1.0);
  ~IdleStreamReaper();
  IdleStreamReaper(const IdleStreamReaper&) = delete;
  IdleStreamReaper& operator=(const IdleStreamReaper&) = delete;

  // What EndAll does to a stream: long-lived streams (a robot's sensor stream, a camera's
  // recognition stream) never end on their own and are ended; finite uploads (BulkEnroll,
  // StreamEnroll) are left to finish within the shutdown grace, so no view a client is sending is
  // cut off. The idle limit applies to both.
  enum class AtShutdown { kEnd, kLetFinish };
  // Asked from the reaper's thread, possibly after the call ended: it must not use the call's
  // context (Authenticator::Revalidation copies what it needs).
  using Revalidation = std::function<absl::Status()>;
  std::unique_ptr<Watch> WatchStream(grpc::ServerContextBase* context,
                                     AtShutdown at_shutdown = AtShutdown::kEnd,
                                     Revalidation revalidate = nullptr);
  double idle_seconds() const { return idle_seconds_; }

  // Ends every watched kEnd stream, and every one watched from now on, with `code` and `message`
  // (what the client's Finish() returns; the handler's Read fails). For the server's shutdown,
  // once the state the streams fed is saved.
  void EndAll(grpc::StatusCode code, const std::string& message);

 private:
  using Clock = std::chrono::steady_clock;
  struct Entry {
    Clock::time_point last_activity;
    bool reaped = false;
    AtShutdown at_shutdown = AtShutdown::kEnd;
    Revalidation revalidate;
    uint64_t serial = 0;  // tells apart a watch made at an address another one had
  };
  void Loop();
  // Under `lock`: ends the streams idle too long.
  void ReapIdleLocked(Clock::time_point now);
  // Asks every stream's revalidation with the lock released (it may read the database), then
  // ends those no longer allowed.
  void RevalidateUnlocked(std::unique_lock<std::mutex>& lock);
  // Under mutex_: ends the call of `watch` with the EndAll status, or with `code` and `message`.
  void EndLocked(const Watch* watch);
  void EndWithStatusLocked(const Watch* watch, grpc::StatusCode code, const std::string& message);

  const double idle_seconds_;
  const double revalidate_seconds_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool ending_all_ = false;  // EndAll was called
  grpc::StatusCode end_code_ = grpc::StatusCode::UNAVAILABLE;
  std::string end_message_;
  std::map<const Watch*, Entry> watched_;
  uint64_t next_serial_ = 0;
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_IDLE_STREAM_REAPER_H_
