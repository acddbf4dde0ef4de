#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_STATE_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_STATE_H_

// The live view's channels and viewers, and the Foxglove WebSocket protocol between them
// (foxglove/ws-protocol's spec, v1: serverInfo, advertise, unadvertise, status; subscribe,
// unsubscribe; binary Message Data frames). No sockets here: live_server.h moves the bytes, the
// publisher (live_publisher.h) advertises channels and publishes messages. Thread-safe: one
// mutex, held only to move pointers and small values.
//
// What a viewer is owed is bounded whatever it reads:
//   - data: one slot per subscribed channel holding the newest message (a shared, immutable
//     payload: N viewers of one grid hold one copy). A message that finds the slot still full
//     replaces it, and the one it replaces is counted as skipped for that viewer;
//   - control (advertise, unadvertise, status): a queue of at most `max_control_messages`; a
//     viewer that lets it fill is dropped (it would have to be resent the whole channel list).
// A channel keeps its last message, sent at once to a new subscriber (a viewer that joins sees
// the map without waiting for it to change).

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/string_view.h"
#include "server/service/live/folder.h"
#include "server/service/live/live_schemas.h"

namespace waymark::service::live {

// One message to write to a viewer's socket.
struct Outgoing {
  std::string bytes;  // a JSON text, or a binary frame (opcode, subscription id, time, payload)
  bool binary = false;
  uint32_t channel = 0;  // data: its channel, 0 for control
};

struct ViewerStats {
  uint64_t id = 0;
  std::string who;           // the caller, as in the log
  uint64_t sent = 0;         // data messages handed to the socket
  uint64_t skipped = 0;      // replaced by a newer one before they went out
  uint64_t subscriptions = 0;
  size_t pending_bytes = 0;  // payloads waiting in its slots (shared with other viewers)
  double idle_seconds = 0;   // since it last took a message with messages waiting (0 = none)
};

class LiveState {
 public:
  using Clock = std::chrono::steady_clock;

  explicit LiveState(std::string server_name, size_t max_control_messages = 4096)
      : server_name_(std::move(server_name)), max_control_(max_control_messages) {}

  // --- channels (the publisher) ---
  // Advertises a channel to every viewer; returns its id (ids are never reused).
  uint32_t Advertise(const std::string& topic, const ChannelSchema& schema);
  // Withdraws channels: their subscriptions end, their unsent messages go.
  void Unadvertise(const std::vector<uint32_t>& channels);
  // Whether any viewer subscribes to `channel`: the publisher builds no message nobody wants.
  bool Subscribed(uint32_t channel) const;
  // The channel's newest message, for every viewer subscribed to it. `log_time` in ns.
  void Publish(uint32_t channel, uint64_t log_time, std::shared_ptr<const std::string> payload);
  // A status message (level 0 info, 1 warning, 2 error) to every viewer.
  void BroadcastStatus(int level, const std::string& message);

  // --- viewers (the socket side) ---
  // A new viewer: serverInfo and the advertise of every channel are queued for it.
  uint64_t AddViewer(const std::string& who);
  void RemoveViewer(uint64_t viewer);
  // A text message from the viewer (subscribe, unsubscribe; the rest is answered with a status
  // saying it is not supported). Binary messages are refused the same way.
  void HandleText(uint64_t viewer, absl::string_view text);
  void HandleBinary(uint64_t viewer);
  // The next message to write to the viewer (control first, then the data slots in turn), or
  // nothing. Marks the viewer as having made progress.
  std::optional<Outgoing> Next(uint64_t viewer);
  // Viewers with something to write.
  std::vector<uint64_t> ViewersWithWork() const;
  // Viewers to drop: their control queue overflowed, or they had messages waiting and took none
  // for `stall` (the socket would not take more).
  std::vector<uint64_t> ViewersToDrop(Clock::duration stall) const;

  size_t viewers() const;
  std::vector<ViewerStats> Stats() const;
  uint64_t dropped_viewers() const;  // counted by the server when it drops one
  void CountDropped();

 private:
  struct Channel {
    std::string topic;
    const ChannelSchema* schema = nullptr;
    std::shared_ptr<const std::string> last;  // the newest message, for new subscribers
    uint64_t last_time = 0;
  };
  struct Slot {
    std::shared_ptr<const std::string> payload;
    uint64_t log_time = 0;
  };
  struct Viewer {
    std::string who;
    std::deque<std::string> control;
    bool overflowed = false;
    std::map<uint32_t, uint32_t> subscription_of_channel;  // channel -> subscription id
    std::map<uint32_t, uint32_t> channel_of_subscription;
    std::map<uint32_t, Slot> slots;  // channel -> newest unsent message
    uint32_t next_channel = 0;       // round robin over the slots
    uint64_t sent = 0;
    uint64_t skipped = 0;
    Clock::time_point waiting_since{};  // first unsent message since the last progress
  };

  std::string AdvertiseJson(const std::vector<uint32_t>& channels) const;  // mu_ held
  void QueueControl(Viewer& viewer, std::string message);                  // mu_ held
  void QueueStatus(Viewer& viewer, int level, const std::string& message);  // mu_ held
  void Fill(Viewer& viewer, uint32_t channel, const Channel& source);       // mu_ held

  const std::string server_name_;
  const size_t max_control_;
  mutable std::mutex mu_;
  uint32_t next_channel_id_ = 1;
  std::map<uint32_t, Channel> channels_;
  uint64_t next_viewer_id_ = 1;
  std::map<uint64_t, Viewer> viewers_;
  uint64_t dropped_ = 0;
};

// The Message Data frame of the protocol: 0x01, u32 subscription id, u64 log time (ns), payload,
// integers little-endian.
std::string MessageDataFrame(uint32_t subscription, uint64_t log_time, absl::string_view payload);

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_STATE_H_
