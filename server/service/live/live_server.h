#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_SERVER_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_SERVER_H_

// The live view (issue 37, docs/live-view.md): waymark-server --live ADDR serves, on one address,
//   - the Foxglove WebSocket protocol (subprotocol foxglove.websocket.v1 or foxglove.sdk.v1, the
//     name the Foxglove SDK and foxglove_bridge >= 3.2 use for the same protocol): every open
//     session as a set of channels (live_publisher.h), JSON encoded by foxglove's schemas;
//   - GET /       one page (plain JS and a canvas, live_page.h) that connects to that WebSocket;
//   - GET /stats  the viewers, what each was sent and skipped, and what it has waiting (JSON).
// With authentication on, every request needs a viewer (or admin) token: the `token` query
// parameter or an "Authorization: Bearer" header (401 without one, 403 for another role).
//
// The WebSocket and HTTP library is libwebsockets (Debian 12's libwebsockets-dev, 4.1): one
// event-loop thread serves every viewer, and it writes to a viewer only when that viewer's socket
// can take more (its WRITEABLE callback); a partial write is finished by lws before the next
// callback. So what a viewer costs is bounded by design: its socket's send buffer (SO_SNDBUF, set
// here) and one message in flight, the rest being one latest-value slot per subscribed channel
// (live_state.h). civetweb, which prometheus-cpp's pull endpoint already links, was the other
// candidate: it gives each connection a thread and its websocket write blocks that thread until
// the socket takes the whole frame, or gives up after its request timeout mid-frame (the stream is
// then corrupt); we would have needed a writer thread per viewer to keep one slow viewer from
// holding up the others. Both are maintained in Debian and both do TLS with OpenSSL.
//
// Threads: the lws service thread (sockets, HTTP, the protocol) and the publisher thread (reads
// the sessions every tick_seconds and fills the viewers' slots, then wakes the lws thread with
// lws_cancel_service, the one lws call made from another thread). Robots' threads only touch the
// hub (live_hub.h) and never wait on either.

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "server/service/auth/authenticator.h"
#include "server/service/crossing/crossing_registry.h"
#include "server/service/live/folder.h"
#include "server/service/live/live_hub.h"
#include "server/service/live/live_options.h"
#include "server/service/live/live_publisher.h"
#include "server/service/live/live_state.h"
#include "server/service/slam/slam_registry.h"

struct lws_context;

namespace waymark::service::live {

class LiveServer {
 public:
  // Listens on options.host:port and starts both threads; `crossing` may be null (no
  // recognitions channel data). None of the pointers is owned; all must outlive the server.
  // FAILED_PRECONDITION when it cannot listen.
  static absl::StatusOr<std::unique_ptr<LiveServer>> Start(const LiveOptions& options,
                                                           SlamRegistry* slam,
                                                           CrossingRegistry* crossing,
                                                           Authenticator* auth);
  ~LiveServer();  // Stop()
  LiveServer(const LiveServer&) = delete;
  LiveServer& operator=(const LiveServer&) = delete;

  int port() const { return port_; }
  const std::string& host() const { return options_.host; }
  // Stops serving: the observers are removed, the threads joined. Idempotent.
  void Stop();

  // The viewers, what each was sent and skipped and has waiting, as JSON (GET /stats).
  std::string StatsJson() const;

  // The lws callbacks' way in (live_server.cc); not for other callers.
  struct Internals;
  const LiveOptions& options() const { return options_; }
  LiveState& state() { return state_; }
  LiveHub& hub() { return hub_; }
  Authenticator* auth() { return auth_; }
  void ServiceWake();  // on the lws thread, after lws_cancel_service

 private:
  LiveServer(const LiveOptions& options, SlamRegistry* slam, CrossingRegistry* crossing,
             Authenticator* auth);
  void PublisherLoop();

  const LiveOptions options_;
  SlamRegistry* const slam_;
  CrossingRegistry* const crossing_;
  Authenticator* const auth_;
  LiveHub hub_;
  LiveState state_;
  LivePublisher publisher_;
  std::unique_ptr<Internals> internals_;
  lws_context* context_ = nullptr;
  int port_ = 0;
  uint64_t observer_id_ = 0;
  std::atomic<bool> stopping_{false};
  std::mutex stop_mu_;
  std::condition_variable stop_cv_;
  std::thread service_thread_;
  std::thread publisher_thread_;
  bool stopped_ = false;
};

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_SERVER_H_
