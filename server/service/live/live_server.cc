#include "server/service/live/live_server.h"

#include <libwebsockets.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>

#include <chrono>
#include <cstring>
#include <map>
#include <optional>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/service/live/live_page.h"

namespace waymark::service::live {

namespace {

constexpr size_t kMaxClientMessageBytes = 64 * 1024;
constexpr const char* kSubprotocols[] = {"foxglove.websocket.v1", "foxglove.sdk.v1"};

// One HTTP request (the page, /stats, or a refusal): the body waits here for the socket.
struct HttpSession {
  std::string* body;
  size_t sent;
};

// One viewer's WebSocket.
struct WsSession {
  uint64_t viewer;
  std::string* partial;  // a fragmented text message being received
};

}  // namespace

struct LiveServer::Internals {
  LiveServer* server = nullptr;
  lws_protocols protocols[4]{};
  std::map<uint64_t, lws*> sockets;  // the lws thread only
};

namespace {

LiveServer::Internals& InternalsOf(lws* wsi) {
  return *static_cast<LiveServer::Internals*>(lws_context_user(lws_get_context(wsi)));
}

// The token of a request: ?token=... or "Authorization: Bearer ...", "" for none.
std::string RequestToken(lws* wsi) {
  char buf[512];
  const char* value = lws_get_urlarg_by_name(wsi, "token=", buf, sizeof(buf));
  if (value != nullptr && *value != '\0') return value;
  const int length = lws_hdr_total_length(wsi, WSI_TOKEN_HTTP_AUTHORIZATION);
  if (length <= 0 || length >= static_cast<int>(sizeof(buf))) return "";
  if (lws_hdr_copy(wsi, buf, sizeof(buf), WSI_TOKEN_HTTP_AUTHORIZATION) < 0) return "";
  absl::string_view header(buf);
  if (!absl::StartsWithIgnoreCase(header, "bearer ")) return "";
  return std::string(absl::StripAsciiWhitespace(header.substr(7)));
}

// The caller may watch, or the HTTP status and message that refuse it.
struct Refusal {
  unsigned int status = 0;
  std::string message;
};
std::optional<Refusal> Authorize(LiveServer::Internals& in, lws* wsi, std::string* who);

std::string PeerName(lws* wsi) {
  char ip[64] = {0};
  lws_get_peer_simple(wsi, ip, sizeof(ip));
  return ip;
}

// Answers an HTTP request with `status` and `body` (written when the socket is writable).
int Respond(lws* wsi, HttpSession* session, unsigned int status, const char* type,
            std::string body) {
  unsigned char headers[LWS_PRE + 1024];
  unsigned char* start = &headers[LWS_PRE];
  unsigned char* p = start;
  unsigned char* end = &headers[sizeof(headers) - 1];
  if (lws_add_http_common_headers(wsi, status, type, body.size(), &p, end) != 0) return 1;
  if (lws_add_http_header_by_token(wsi, WSI_TOKEN_HTTP_CACHE_CONTROL,
                                   reinterpret_cast<const unsigned char*>("no-store"), 8, &p,
                                   end) != 0) {
    return 1;
  }
  if (lws_finalize_write_http_header(wsi, start, &p, end) != 0) return 1;
  session->body = new std::string(std::move(body));
  session->sent = 0;
  lws_callback_on_writable(wsi);
  return 0;
}

int HttpCallback(lws* wsi, lws_callback_reasons reason, void* user, void* in, size_t len) {
  auto* session = static_cast<HttpSession*>(user);
  switch (reason) {
    case LWS_CALLBACK_HTTP: {
      LiveServer::Internals& internals = InternalsOf(wsi);
      const std::string path(static_cast<const char*>(in), len);
      std::string who;
      if (std::optional<Refusal> refused = Authorize(internals, wsi, &who); refused.has_value()) {
        return Respond(wsi, session, refused->status, "text/plain; charset=utf-8",
                       refused->message + "\n");
      }
      if (path == "/" || path == "/index.html") {
        return Respond(wsi, session, HTTP_STATUS_OK, "text/html; charset=utf-8",
                       std::string(LivePage()));
      }
      if (path == "/stats") {
        return Respond(wsi, session, HTTP_STATUS_OK, "application/json",
                       internals.server->StatsJson());
      }
      return Respond(wsi, session, HTTP_STATUS_NOT_FOUND, "text/plain; charset=utf-8",
                     "not found: the live view serves / (the page), /stats and the WebSocket\n");
    }
    case LWS_CALLBACK_HTTP_WRITEABLE: {
      if (session == nullptr || session->body == nullptr) break;
      const size_t chunk = std::min<size_t>(session->body->size() - session->sent, 64 * 1024);
      std::vector<unsigned char> buffer(LWS_PRE + chunk);
      std::memcpy(buffer.data() + LWS_PRE, session->body->data() + session->sent, chunk);
      const bool last = session->sent + chunk >= session->body->size();
      if (lws_write(wsi, buffer.data() + LWS_PRE, chunk,
                    last ? LWS_WRITE_HTTP_FINAL : LWS_WRITE_HTTP) != static_cast<int>(chunk)) {
        return 1;
      }
      session->sent += chunk;
      if (!last) {
        lws_callback_on_writable(wsi);
        break;
      }
      delete session->body;
      session->body = nullptr;
      if (lws_http_transaction_completed(wsi)) return -1;
      break;
    }
    case LWS_CALLBACK_CLOSED_HTTP:
    case LWS_CALLBACK_HTTP_DROP_PROTOCOL:
      if (session != nullptr) {
        delete session->body;
        session->body = nullptr;
      }
      break;
    case LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION:
      // A WebSocket that named neither of the protocol's subprotocols.
      return 1;
    case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
      InternalsOf(wsi).server->ServiceWake();
      break;
    default:
      break;
  }
  return lws_callback_http_dummy(wsi, reason, user, in, len);
}

int WsCallback(lws* wsi, lws_callback_reasons reason, void* user, void* in, size_t len) {
  auto* session = static_cast<WsSession*>(user);
  switch (reason) {
    case LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION: {
      LiveServer::Internals& internals = InternalsOf(wsi);
      std::string who;
      if (std::optional<Refusal> refused = Authorize(internals, wsi, &who); refused.has_value()) {
        spdlog::info("live view: refused a viewer from {}: {}", PeerName(wsi), refused->message);
        lws_return_http_status(wsi, refused->status, refused->message.c_str());
        return 1;
      }
      if (static_cast<int>(internals.sockets.size()) >= internals.server->options().max_viewers) {
        lws_return_http_status(wsi, HTTP_STATUS_SERVICE_UNAVAILABLE, "too many viewers");
        return 1;
      }
      return 0;
    }
    case LWS_CALLBACK_ESTABLISHED: {
      LiveServer::Internals& internals = InternalsOf(wsi);
      const int fd = lws_get_socket_fd(wsi);
      const int sndbuf = internals.server->options().socket_send_buffer;
      if (fd >= 0 && sndbuf > 0) setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof(sndbuf));
      const char* protocol = lws_get_protocol(wsi)->name;
      const std::string who = absl::StrCat(PeerName(wsi), " (", protocol, ")");
      session->viewer = internals.server->state().AddViewer(who);
      session->partial = nullptr;
      internals.sockets[session->viewer] = wsi;
      internals.server->hub().set_watched(true);
      spdlog::info("live view: viewer {} connected from {}", session->viewer, who);
      lws_callback_on_writable(wsi);
      break;
    }
    case LWS_CALLBACK_RECEIVE: {
      if (lws_frame_is_binary(wsi)) {
        InternalsOf(wsi).server->state().HandleBinary(session->viewer);
        lws_callback_on_writable(wsi);
        break;
      }
      if (session->partial == nullptr) session->partial = new std::string();
      if (session->partial->size() + len > kMaxClientMessageBytes) {
        lws_close_reason(wsi, LWS_CLOSE_STATUS_MESSAGE_TOO_LARGE, nullptr, 0);
        return -1;
      }
      session->partial->append(static_cast<const char*>(in), len);
      if (lws_is_final_fragment(wsi) && lws_remaining_packet_payload(wsi) == 0) {
        InternalsOf(wsi).server->state().HandleText(session->viewer, *session->partial);
        session->partial->clear();
        lws_callback_on_writable(wsi);
      }
      break;
    }
    case LWS_CALLBACK_SERVER_WRITEABLE: {
      LiveState& state = InternalsOf(wsi).server->state();
      std::optional<Outgoing> next = state.Next(session->viewer);
      if (!next.has_value()) break;
      std::vector<unsigned char> buffer(LWS_PRE + next->bytes.size());
      std::memcpy(buffer.data() + LWS_PRE, next->bytes.data(), next->bytes.size());
      const int written = lws_write(wsi, buffer.data() + LWS_PRE, next->bytes.size(),
                                    next->binary ? LWS_WRITE_BINARY : LWS_WRITE_TEXT);
      if (written < 0) return -1;
      // lws finishes a partial write itself, before it calls this again.
      lws_callback_on_writable(wsi);
      break;
    }
    case LWS_CALLBACK_CLOSED: {
      LiveServer::Internals& internals = InternalsOf(wsi);
      internals.server->state().RemoveViewer(session->viewer);
      internals.sockets.erase(session->viewer);
      if (internals.sockets.empty()) internals.server->hub().set_watched(false);
      delete session->partial;
      session->partial = nullptr;
      spdlog::info("live view: viewer {} left", session->viewer);
      break;
    }
    default:
      break;
  }
  return 0;
}

std::optional<Refusal> Authorize(LiveServer::Internals& in, lws* wsi, std::string* who) {
  absl::StatusOr<Caller> caller =
      in.server->auth()->AuthorizeSecret(RequestToken(wsi), Action::kLiveView);
  if (caller.ok()) {
    *who = caller->Describe();
    return std::nullopt;
  }
  const bool unauthenticated = caller.status().code() == absl::StatusCode::kUnauthenticated;
  return Refusal{unauthenticated ? 401u : 403u, std::string(caller.status().message())};
}

void LogToSpdlog(int level, const char* line) {
  std::string text(line);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (level & LLL_ERR) {
    spdlog::error("live view (lws): {}", text);
  } else {
    spdlog::warn("live view (lws): {}", text);
  }
}

}  // namespace

absl::StatusOr<std::unique_ptr<LiveServer>> LiveServer::Start(const LiveOptions& options,
                                                              SlamRegistry* slam,
                                                              CrossingRegistry* crossing,
                                                              Authenticator* auth) {
  std::unique_ptr<LiveServer> server(new LiveServer(options, slam, crossing, auth));
  Internals& in = *server->internals_;
  in.server = server.get();
  in.protocols[0] = {"http", HttpCallback, sizeof(HttpSession), 0, 0, nullptr, 0};
  for (int i = 0; i < 2; ++i) {
    in.protocols[1 + i] = {kSubprotocols[i], WsCallback, sizeof(WsSession),
                           kMaxClientMessageBytes, 0, nullptr, 0};
  }
  in.protocols[3] = {nullptr, nullptr, 0, 0, 0, nullptr, 0};

  lws_set_log_level(LLL_ERR | LLL_WARN, LogToSpdlog);
  lws_context_creation_info info;
  std::memset(&info, 0, sizeof(info));
  info.port = options.port;
  info.iface = options.host.c_str();
  info.protocols = in.protocols;
  info.user = &in;
  info.options = LWS_SERVER_OPTION_DISABLE_IPV6;
  info.vhost_name = "waymark-live";
  info.timeout_secs = 30;  // an HTTP request or handshake that stalls
  info.ka_time = 60;       // TCP keepalive: a viewer whose machine vanished goes
  info.ka_probes = 3;
  info.ka_interval = 10;
  server->context_ = lws_create_context(&info);
  if (server->context_ == nullptr) {
    return absl::FailedPreconditionError(absl::StrCat(
        "--live: cannot listen on ", options.host, ":", options.port,
        " (address in use, or not an address of this machine?)"));
  }
  lws_vhost* vhost = lws_get_vhost_by_name(server->context_, "waymark-live");
  server->port_ = vhost != nullptr ? lws_get_vhost_listen_port(vhost) : options.port;

  server->observer_id_ = slam->AddObserver(SlamObserver{
      [hub = &server->hub_](const std::string& id, const v1::SlamUpdate& update) {
        hub->OnUpdate(id, update);
      },
      [hub = &server->hub_](const std::string& id, const v1::SensorData& data) {
        hub->OnInput(id, data);
      },
      // Its slots go with it, before the next session list would drop them.
      [hub = &server->hub_](const std::string& id) { hub->Forget(id); }});
  if (crossing != nullptr) {
    crossing->SetRecognitionObserver(
        [hub = &server->hub_](const std::string& database, const v1::RecognizeResponse& response) {
          hub->OnRecognition(database, response);
        });
  }
  LiveServer* raw = server.get();
  server->service_thread_ = std::thread([raw] {
    while (!raw->stopping_.load()) lws_service(raw->context_, 0);
  });
  server->publisher_thread_ = std::thread([raw] { raw->PublisherLoop(); });
  return server;
}

LiveServer::LiveServer(const LiveOptions& options, SlamRegistry* slam, CrossingRegistry* crossing,
                       Authenticator* auth)
    : options_(options),
      slam_(slam),
      crossing_(crossing),
      auth_(auth),
      hub_(options.scan_ring),
      state_("waymark-server"),
      publisher_(slam, &hub_, &state_, options_),
      internals_(std::make_unique<Internals>()) {}

LiveServer::~LiveServer() { Stop(); }

void LiveServer::Stop() {
  if (stopped_) return;
  stopped_ = true;
  slam_->RemoveObserver(observer_id_);
  if (crossing_ != nullptr) crossing_->SetRecognitionObserver(nullptr);
  {
    std::lock_guard<std::mutex> lock(stop_mu_);
    stopping_ = true;
  }
  stop_cv_.notify_all();
  if (publisher_thread_.joinable()) publisher_thread_.join();
  if (context_ != nullptr) lws_cancel_service(context_);
  if (service_thread_.joinable()) service_thread_.join();
  if (context_ != nullptr) lws_context_destroy(context_);
  context_ = nullptr;
}

void LiveServer::PublisherLoop() {
  const auto tick = std::chrono::duration_cast<LivePublisher::Clock::duration>(
      std::chrono::duration<double>(options_.tick_seconds));
  auto next = LivePublisher::Clock::now();
  std::unique_lock<std::mutex> lock(stop_mu_);
  while (!stopping_) {
    lock.unlock();
    if (state_.viewers() > 0) publisher_.Tick(LivePublisher::Clock::now());
    lws_cancel_service(context_);  // the lws thread writes what the round left for the viewers
    lock.lock();
    next += tick;
    const auto now = LivePublisher::Clock::now();
    if (next < now) next = now;  // a slow round is not made up for
    stop_cv_.wait_until(lock, next, [this] { return stopping_.load(); });
  }
}

// On the lws thread, after lws_cancel_service: ask for a write on every viewer with something
// waiting; drop the ones that stopped taking anything.
void LiveServer::ServiceWake() {
  const auto stall = std::chrono::duration_cast<LiveState::Clock::duration>(
      std::chrono::duration<double>(options_.stall_seconds));
  for (uint64_t viewer : state_.ViewersToDrop(stall)) {
    const auto found = internals_->sockets.find(viewer);
    if (found == internals_->sockets.end()) continue;
    spdlog::warn("live view: dropping viewer {}: it took nothing for {} s (slow link, or it "
                  "stopped reading)",
                  viewer, options_.stall_seconds);
    state_.CountDropped();
    state_.RemoveViewer(viewer);
    lws_set_timeout(found->second, PENDING_TIMEOUT_CLOSE_SEND, LWS_TO_KILL_ASYNC);
  }
  for (uint64_t viewer : state_.ViewersWithWork()) {
    const auto found = internals_->sockets.find(viewer);
    if (found != internals_->sockets.end()) lws_callback_on_writable(found->second);
  }
}

std::string LiveServer::StatsJson() const {
  nlohmann::json viewers = nlohmann::json::array();
  for (const ViewerStats& s : state_.Stats()) {
    viewers.push_back({{"id", s.id},
                       {"who", s.who},
                       {"sent", s.sent},
                       {"skipped", s.skipped},
                       {"subscriptions", s.subscriptions},
                       {"pending_bytes", s.pending_bytes},
                       {"idle_seconds", s.idle_seconds}});
  }
  return nlohmann::json{{"viewers", std::move(viewers)},
                        {"dropped_viewers", state_.dropped_viewers()},
                        {"sessions_watched", hub_.sessions()},
                        {"grids_rendered", publisher_.grids_rendered()},
                        {"grid_render_seconds", publisher_.grid_render_seconds()}}
             .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace waymark::service::live
