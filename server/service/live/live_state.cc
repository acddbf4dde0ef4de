#include "server/service/live/live_state.h"

#include <nlohmann/json.hpp>
#include <utility>

#include "absl/strings/str_cat.h"

namespace waymark::service::live {
namespace {

using nlohmann::json;

std::string Dump(const json& value) {
  return value.dump(-1, ' ', false, json::error_handler_t::replace);
}

void PutLittleEndian(std::string& out, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

}  // namespace

std::string MessageDataFrame(uint32_t subscription, uint64_t log_time, absl::string_view payload) {
  std::string frame;
  frame.reserve(13 + payload.size());
  frame.push_back(0x01);
  PutLittleEndian(frame, subscription, 4);
  PutLittleEndian(frame, log_time, 8);
  frame.append(payload.data(), payload.size());
  return frame;
}

// ---------------------------------------------------------------------------------------------
// Channels

std::string LiveState::AdvertiseJson(const std::vector<uint32_t>& ids) const {
  json channels = json::array();
  for (uint32_t id : ids) {
    const auto found = channels_.find(id);
    if (found == channels_.end()) continue;
    channels.push_back({{"id", id},
                        {"topic", found->second.topic},
                        {"encoding", "json"},
                        {"schemaName", found->second.schema->schema_name},
                        {"schema", found->second.schema->schema},
                        {"schemaEncoding", "jsonschema"}});
  }
  return Dump({{"op", "advertise"}, {"channels", std::move(channels)}});
}

void LiveState::QueueControl(Viewer& viewer, std::string message) {
  if (viewer.control.size() >= max_control_) {
    viewer.overflowed = true;  // dropped by the server at its next check
    return;
  }
  if (viewer.control.empty() && viewer.slots.empty()) viewer.waiting_since = Clock::now();
  viewer.control.push_back(std::move(message));
}

void LiveState::QueueStatus(Viewer& viewer, int level, const std::string& message) {
  QueueControl(viewer, Dump({{"op", "status"}, {"level", level}, {"message", message}}));
}

uint32_t LiveState::Advertise(const std::string& topic, const ChannelSchema& schema) {
  std::lock_guard<std::mutex> lock(mu_);
  const uint32_t id = next_channel_id_++;
  channels_[id] = Channel{topic, &schema, nullptr, 0};
  if (!viewers_.empty()) {
    const std::string message = AdvertiseJson({id});
    for (auto& [viewer_id, viewer] : viewers_) QueueControl(viewer, message);
  }
  return id;
}

void LiveState::Unadvertise(const std::vector<uint32_t>& ids) {
  if (ids.empty()) return;
  std::lock_guard<std::mutex> lock(mu_);
  for (uint32_t id : ids) channels_.erase(id);
  const std::string message = Dump({{"op", "unadvertise"}, {"channelIds", ids}});
  for (auto& [viewer_id, viewer] : viewers_) {
    for (uint32_t id : ids) {
      viewer.slots.erase(id);
      const auto sub = viewer.subscription_of_channel.find(id);
      if (sub != viewer.subscription_of_channel.end()) {
        viewer.channel_of_subscription.erase(sub->second);
        viewer.subscription_of_channel.erase(sub);
      }
    }
    QueueControl(viewer, message);
  }
}

bool LiveState::Subscribed(uint32_t channel) const {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, viewer] : viewers_) {
    if (viewer.subscription_of_channel.count(channel) > 0) return true;
  }
  return false;
}

void LiveState::Fill(Viewer& viewer, uint32_t channel, const Channel& source) {
  Slot& slot = viewer.slots[channel];
  if (slot.payload != nullptr) {
    ++viewer.skipped;
  } else if (viewer.control.empty() && viewer.slots.size() == 1) {
    viewer.waiting_since = Clock::now();
  }
  slot.payload = source.last;
  slot.log_time = source.last_time;
}

void LiveState::Publish(uint32_t channel, uint64_t log_time,
                        std::shared_ptr<const std::string> payload) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto found = channels_.find(channel);
  if (found == channels_.end()) return;
  found->second.last = std::move(payload);
  found->second.last_time = log_time;
  for (auto& [id, viewer] : viewers_) {
    if (viewer.subscription_of_channel.count(channel) > 0) Fill(viewer, channel, found->second);
  }
}

void LiveState::BroadcastStatus(int level, const std::string& message) {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& [id, viewer] : viewers_) QueueStatus(viewer, level, message);
}

// ---------------------------------------------------------------------------------------------
// Viewers

uint64_t LiveState::AddViewer(const std::string& who) {
  std::lock_guard<std::mutex> lock(mu_);
  const uint64_t id = next_viewer_id_++;
  Viewer& viewer = viewers_[id];
  viewer.who = who;
  // No optional capability: the view is read-only (no client publishing, parameters, services)
  // and its timestamps are the robots' own.
  QueueControl(viewer, Dump({{"op", "serverInfo"},
                             {"name", server_name_},
                             {"capabilities", json::array()},
                             {"metadata", {{"docs", "docs/live-view.md"}}}}));
  std::vector<uint32_t> ids;
  for (const auto& [channel, unused] : channels_) ids.push_back(channel);
  QueueControl(viewer, AdvertiseJson(ids));
  return id;
}

void LiveState::RemoveViewer(uint64_t viewer) {
  std::lock_guard<std::mutex> lock(mu_);
  viewers_.erase(viewer);
}

void LiveState::HandleText(uint64_t viewer_id, absl::string_view text) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto found = viewers_.find(viewer_id);
  if (found == viewers_.end()) return;
  Viewer& viewer = found->second;
  const json message = json::parse(text.begin(), text.end(), nullptr, false);
  if (message.is_discarded() || !message.is_object() || !message.contains("op") ||
      !message["op"].is_string()) {
    QueueStatus(viewer, 2, "expected a JSON object with a string \"op\"");
    return;
  }
  const std::string op = message["op"].get<std::string>();
  if (op == "subscribe") {
    if (!message.contains("subscriptions") || !message["subscriptions"].is_array()) {
      QueueStatus(viewer, 2, "subscribe needs a \"subscriptions\" array");
      return;
    }
    for (const json& sub : message["subscriptions"]) {
      if (!sub.is_object() || !sub.contains("id") || !sub.contains("channelId") ||
          !sub["id"].is_number_unsigned() || !sub["channelId"].is_number_unsigned() ||
          sub["id"].get<uint64_t>() > UINT32_MAX || sub["channelId"].get<uint64_t>() > UINT32_MAX) {
        QueueStatus(viewer, 2, "a subscription needs unsigned 32-bit \"id\" and \"channelId\"");
        continue;
      }
      const uint32_t id = sub["id"].get<uint32_t>();
      const uint32_t channel = sub["channelId"].get<uint32_t>();
      const auto source = channels_.find(channel);
      if (source == channels_.end()) {
        QueueStatus(viewer, 1, absl::StrCat("no channel ", channel, " (withdrawn, or never advertised)"));
        continue;
      }
      if (viewer.channel_of_subscription.count(id) > 0) {
        QueueStatus(viewer, 2, absl::StrCat("subscription id ", id, " is already in use"));
        continue;
      }
      if (viewer.subscription_of_channel.count(channel) > 0) {
        QueueStatus(viewer, 1, absl::StrCat("channel ", channel, " is already subscribed"));
        continue;
      }
      viewer.subscription_of_channel[channel] = id;
      viewer.channel_of_subscription[id] = channel;
      if (source->second.last != nullptr) Fill(viewer, channel, source->second);
    }
    return;
  }
  if (op == "unsubscribe") {
    if (!message.contains("subscriptionIds") || !message["subscriptionIds"].is_array()) {
      QueueStatus(viewer, 2, "unsubscribe needs a \"subscriptionIds\" array");
      return;
    }
    for (const json& id : message["subscriptionIds"]) {
      if (!id.is_number_unsigned() || id.get<uint64_t>() > UINT32_MAX) continue;
      const auto sub = viewer.channel_of_subscription.find(id.get<uint32_t>());
      if (sub == viewer.channel_of_subscription.end()) continue;
      viewer.slots.erase(sub->second);
      viewer.subscription_of_channel.erase(sub->second);
      viewer.channel_of_subscription.erase(sub);
    }
    return;
  }
  QueueStatus(viewer, 1,
              absl::StrCat("\"", op.substr(0, 64),
                           "\" is not supported: this server is read-only (subscribe, "
                           "unsubscribe)"));
}

void LiveState::HandleBinary(uint64_t viewer_id) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto found = viewers_.find(viewer_id);
  if (found == viewers_.end()) return;
  QueueStatus(found->second, 1, "client messages are not supported: this server is read-only");
}

std::optional<Outgoing> LiveState::Next(uint64_t viewer_id) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto found = viewers_.find(viewer_id);
  if (found == viewers_.end()) return std::nullopt;
  Viewer& viewer = found->second;
  viewer.waiting_since = Clock::now();
  if (!viewer.control.empty()) {
    Outgoing out{std::move(viewer.control.front()), false, 0};
    viewer.control.pop_front();
    return out;
  }
  if (viewer.slots.empty()) return std::nullopt;
  // Round robin: the first channel after the last one sent, so a grid cannot starve the poses.
  auto slot = viewer.slots.upper_bound(viewer.next_channel);
  if (slot == viewer.slots.end()) slot = viewer.slots.begin();
  const uint32_t channel = slot->first;
  viewer.next_channel = channel;
  const uint32_t subscription = viewer.subscription_of_channel.at(channel);
  Outgoing out{MessageDataFrame(subscription, slot->second.log_time, *slot->second.payload), true,
               channel};
  viewer.slots.erase(slot);
  ++viewer.sent;
  return out;
}

std::vector<uint64_t> LiveState::ViewersWithWork() const {
  std::vector<uint64_t> out;
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, viewer] : viewers_) {
    if (!viewer.control.empty() || !viewer.slots.empty()) out.push_back(id);
  }
  return out;
}

std::vector<uint64_t> LiveState::ViewersToDrop(Clock::duration stall) const {
  std::vector<uint64_t> out;
  const Clock::time_point now = Clock::now();
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, viewer] : viewers_) {
    const bool waiting = !viewer.control.empty() || !viewer.slots.empty();
    if (viewer.overflowed || (waiting && now - viewer.waiting_since > stall)) out.push_back(id);
  }
  return out;
}

size_t LiveState::viewers() const {
  std::lock_guard<std::mutex> lock(mu_);
  return viewers_.size();
}

std::vector<ViewerStats> LiveState::Stats() const {
  std::vector<ViewerStats> out;
  const Clock::time_point now = Clock::now();
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [id, viewer] : viewers_) {
    ViewerStats stats;
    stats.id = id;
    stats.who = viewer.who;
    stats.sent = viewer.sent;
    stats.skipped = viewer.skipped;
    stats.subscriptions = viewer.subscription_of_channel.size();
    for (const auto& [channel, slot] : viewer.slots) stats.pending_bytes += slot.payload->size();
    for (const std::string& message : viewer.control) stats.pending_bytes += message.size();
    const bool waiting = !viewer.control.empty() || !viewer.slots.empty();
    stats.idle_seconds =
        waiting ? std::chrono::duration<double>(now - viewer.waiting_since).count() : 0.0;
    out.push_back(std::move(stats));
  }
  return out;
}

uint64_t LiveState::dropped_viewers() const {
  std::lock_guard<std::mutex> lock(mu_);
  return dropped_;
}

void LiveState::CountDropped() {
  std::lock_guard<std::mutex> lock(mu_);
  ++dropped_;
}

}  // namespace waymark::service::live
