// The live view without sockets: the protocol's messages as a viewer receives them (serverInfo,
// advertise, subscribe, Message Data frames), the latest-value slots (a slow viewer skips, never
// queues), the hub pairing each answer with the scan it answered, and the builders' JSON.
#include <gtest/gtest.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "server/service/live/live_hub.h"
#include "server/service/live/live_messages.h"
#include "server/service/live/live_options.h"
#include "server/service/live/live_schemas.h"
#include "server/service/live/live_state.h"

namespace waymark::service::live {
namespace {

using nlohmann::json;

json NextJson(LiveState& state, uint64_t viewer) {
  std::optional<Outgoing> out = state.Next(viewer);
  EXPECT_TRUE(out.has_value());
  if (!out.has_value()) return nullptr;
  EXPECT_FALSE(out->binary);
  return json::parse(out->bytes);
}

std::shared_ptr<const std::string> Text(const std::string& s) {
  return std::make_shared<const std::string>(s);
}

TEST(LiveStateTest, ViewerGetsServerInfoAdvertiseThenItsSubscriptionsNewestFirst) {
  LiveState state("test");
  const uint32_t pose = state.Advertise("/sessions/s1/pose", PoseSchema());
  const uint64_t viewer = state.AddViewer("v");
  EXPECT_EQ(NextJson(state, viewer)["op"], "serverInfo");
  const json advertise = NextJson(state, viewer);
  ASSERT_EQ(advertise["op"], "advertise");
  ASSERT_EQ(advertise["channels"].size(), 1u);
  EXPECT_EQ(advertise["channels"][0]["id"], pose);
  EXPECT_EQ(advertise["channels"][0]["encoding"], "json");
  EXPECT_EQ(advertise["channels"][0]["schemaName"], "foxglove.PoseInFrame");
  EXPECT_EQ(advertise["channels"][0]["schemaEncoding"], "jsonschema");
  EXPECT_FALSE(state.Next(viewer).has_value());
  EXPECT_FALSE(state.Subscribed(pose));

  state.HandleText(viewer, json{{"op", "subscribe"},
                                {"subscriptions", {{{"id", 7}, {"channelId", pose}}}}}
                               .dump());
  EXPECT_TRUE(state.Subscribed(pose));
  // Three messages before the viewer takes any: it gets the newest, two are counted skipped.
  state.Publish(pose, 1, Text("{\"n\":1}"));
  state.Publish(pose, 2, Text("{\"n\":2}"));
  state.Publish(pose, 3, Text("{\"n\":3}"));
  std::optional<Outgoing> data = state.Next(viewer);
  ASSERT_TRUE(data.has_value());
  ASSERT_TRUE(data->binary);
  EXPECT_EQ(data->bytes, MessageDataFrame(7, 3, "{\"n\":3}"));
  EXPECT_FALSE(state.Next(viewer).has_value());
  ASSERT_EQ(state.Stats().size(), 1u);
  EXPECT_EQ(state.Stats()[0].skipped, 2u);
  EXPECT_EQ(state.Stats()[0].sent, 1u);
}

TEST(LiveStateTest, MessageDataFrameIsLittleEndian) {
  const std::string frame = MessageDataFrame(0x01020304, 0x0102030405060708ull, "xy");
  ASSERT_EQ(frame.size(), 1u + 4 + 8 + 2);
  EXPECT_EQ(frame[0], 0x01);
  EXPECT_EQ(frame[1], 0x04);
  EXPECT_EQ(frame[4], 0x01);
  EXPECT_EQ(frame[5], 0x08);
  EXPECT_EQ(frame[12], 0x01);
  EXPECT_EQ(frame.substr(13), "xy");
}

TEST(LiveStateTest, NewSubscriberGetsTheChannelsLastMessage) {
  LiveState state("test");
  const uint32_t grid = state.Advertise("/sessions/s1/grid", GridSchema());
  state.Publish(grid, 5, Text("{\"grid\":1}"));
  const uint64_t viewer = state.AddViewer("v");
  NextJson(state, viewer);
  NextJson(state, viewer);
  state.HandleText(viewer, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" +
                               std::to_string(grid) + "}]}");
  std::optional<Outgoing> data = state.Next(viewer);
  ASSERT_TRUE(data.has_value());
  EXPECT_EQ(data->bytes, MessageDataFrame(1, 5, "{\"grid\":1}"));
}

TEST(LiveStateTest, UnadvertiseEndsSubscriptionsAndDropsUnsentMessages) {
  LiveState state("test");
  const uint32_t pose = state.Advertise("/p", PoseSchema());
  const uint64_t viewer = state.AddViewer("v");
  NextJson(state, viewer);
  NextJson(state, viewer);
  state.HandleText(viewer, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" +
                               std::to_string(pose) + "}]}");
  state.Publish(pose, 1, Text("{}"));
  state.Unadvertise({pose});
  const json withdrawn = NextJson(state, viewer);
  EXPECT_EQ(withdrawn["op"], "unadvertise");
  EXPECT_EQ(withdrawn["channelIds"], json::array({pose}));
  EXPECT_FALSE(state.Next(viewer).has_value()) << "no data after its channel is withdrawn";
  EXPECT_FALSE(state.Subscribed(pose));
}

TEST(LiveStateTest, BadClientMessagesGetAStatusNotACrash) {
  LiveState state("test");
  const uint64_t viewer = state.AddViewer("v");
  NextJson(state, viewer);
  NextJson(state, viewer);
  for (const char* text : {"not json", "[]", R"({"op":3})", R"({"op":"subscribe"})",
                           R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})",
                           R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":99}]})",
                           R"({"op":"setParameters","parameters":[]})"}) {
    state.HandleText(viewer, text);
    const json status = NextJson(state, viewer);
    EXPECT_EQ(status["op"], "status") << text;
    EXPECT_GE(status["level"].get<int>(), 1) << text;
  }
}

TEST(LiveStateTest, AViewerThatTakesNothingIsToBeDropped) {
  LiveState state("test", /*max_control_messages=*/4);
  const uint64_t viewer = state.AddViewer("v");  // serverInfo + advertise queued, never taken
  EXPECT_TRUE(state.ViewersToDrop(std::chrono::hours(1)).empty());
  EXPECT_EQ(state.ViewersToDrop(std::chrono::nanoseconds(0)), std::vector<uint64_t>{viewer});
  for (int i = 0; i < 3; ++i) state.BroadcastStatus(0, "x");  // the control queue overflows
  EXPECT_EQ(state.ViewersToDrop(std::chrono::hours(1)), std::vector<uint64_t>{viewer});
}

TEST(LiveHubTest, EachAnswerIsDrawnWithTheScanItAnswered) {
  LiveHub hub(/*scan_ring=*/4);
  v1::SensorData data;
  data.mutable_scan()->add_ranges(1.0f);
  v1::SlamUpdate update;
  update.set_sequence(1);
  hub.OnUpdate("s", update);
  EXPECT_FALSE(hub.Take("s").update.has_value()) << "nobody watches: nothing kept";
  hub.set_watched(true);
  for (uint64_t seq : {1, 2, 3}) {
    data.set_sequence(seq);
    data.mutable_scan()->set_ranges(0, static_cast<float>(seq));
    hub.OnInput("s", data);
  }
  update.set_sequence(2);
  hub.OnUpdate("s", update);
  LiveHub::Latest latest = hub.Take("s");
  ASSERT_TRUE(latest.update.has_value());
  ASSERT_TRUE(latest.scan.has_value());
  EXPECT_EQ(latest.scan->sequence, 2u);
  EXPECT_EQ(latest.scan->ranges[0], 2.0f);
  EXPECT_FALSE(hub.Take("s").update.has_value()) << "taken once";
  // An answer whose scan fell out of the ring goes without a scan.
  update.set_sequence(9);
  hub.OnUpdate("s", update);
  EXPECT_FALSE(hub.Take("s").scan.has_value());
  hub.Retain({});
  EXPECT_EQ(hub.sessions(), 0u);
}

TEST(LiveMessagesTest, GridIsFoxglovesGridOfTheOccupancyCells) {
  v1::OccupancyGrid grid;
  grid.set_width(3);
  grid.set_height(2);
  grid.set_resolution(0.1);
  grid.mutable_origin()->set_x(-1.5);
  grid.mutable_origin()->set_y(2.0);
  grid.set_cells(std::string("\xff\x00\x64\x01\x02\x03", 6));
  const json out = json::parse(GridJson(grid, 12.25));
  EXPECT_EQ(out["column_count"], 3);
  EXPECT_EQ(out["row_stride"], 3);
  EXPECT_EQ(out["cell_stride"], 1);
  EXPECT_DOUBLE_EQ(out["cell_size"]["x"], 0.1);
  EXPECT_DOUBLE_EQ(out["pose"]["position"]["x"], -1.5);
  EXPECT_DOUBLE_EQ(out["pose"]["position"]["y"], 2.0);
  EXPECT_EQ(out["data"], "/wBkAQID");
  EXPECT_EQ(out["timestamp"]["sec"], 12);
  EXPECT_EQ(out["timestamp"]["nsec"], 250000000);
}

TEST(LiveMessagesTest, ScanIsDrawnFromTheLaserAndNoReturnsAreZero) {
  ScanSample scan;
  scan.angle_min = -1.0;
  scan.angle_increment = 0.5;
  scan.no_return_range = 8.0;
  scan.ranges = {1.0f, std::nanf(""), 8.5f, 0.0f, 2.0f};
  v1::Pose2D robot;
  robot.set_x(1.0);
  robot.set_theta(M_PI / 2);
  v1::Pose2D laser;
  laser.set_x(0.2);
  const json out = json::parse(ScanJson(scan, robot, laser));
  EXPECT_NEAR(out["pose"]["position"]["x"], 1.0, 1e-12);
  EXPECT_NEAR(out["pose"]["position"]["y"], 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(out["start_angle"], -1.0);
  EXPECT_DOUBLE_EQ(out["end_angle"], 1.0);
  EXPECT_EQ(out["ranges"], json::array({1.0, 0.0, 0.0, 0.0, 2.0}));
}

TEST(LiveOptionsTest, ABarePortListensOnTheLoopback) {
  LiveOptions options;
  ASSERT_TRUE(ParseLiveAddress("8765", &options).ok());
  EXPECT_EQ(options.host, "127.0.0.1");
  EXPECT_EQ(options.port, 8765);
  ASSERT_TRUE(ParseLiveAddress("0.0.0.0:9000", &options).ok());
  EXPECT_EQ(options.host, "0.0.0.0");
  EXPECT_EQ(options.port, 9000);
  EXPECT_FALSE(ParseLiveAddress("host:port", &options).ok());
  EXPECT_FALSE(ParseLiveAddress("70000", &options).ok());
  EXPECT_FALSE(ParseLiveAddress("[::1]:80", &options).ok());
}

}  // namespace
}  // namespace waymark::service::live
