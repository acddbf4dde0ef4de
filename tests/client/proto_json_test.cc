#include "client/common/proto_json.h"

#include <gtest/gtest.h>

namespace waymark::cli {
namespace {

TEST(ProtoToJsonTest, KeepsFieldNamesNumbersAndEnums) {
  v1::CrossingDatabase db;
  db.set_id(int64_t{1} << 40);
  db.set_name("campus");
  db.mutable_params()->set_work_width(320);
  db.mutable_params()->mutable_recognition()->set_mode(v1::RECOGNITION_MODE_VERIFIED);
  const nlohmann::json json = ProtoToJson(db);
  EXPECT_EQ(json["id"], int64_t{1} << 40);  // a number, not a string
  EXPECT_EQ(json["name"], "campus");
  EXPECT_EQ(json["views"], 0);  // proto3 scalars always present
  EXPECT_EQ(json["params"]["work_width"], 320);
  EXPECT_FALSE(json["params"].contains("hue_bins"));  // unset optional left out
  EXPECT_EQ(json["params"]["recognition"]["mode"], "verified");
  EXPECT_FALSE(json["params"]["recognition"].contains("ratio"));
}

TEST(ProtoToJsonTest, RepeatedFieldsAreArraysAndBytesAreSizes) {
  v1::RecognizeResponse response;
  response.add_candidates()->set_crossing("A");
  response.add_candidates()->set_crossing("B");
  EXPECT_EQ(ProtoToJson(response)["candidates"].size(), 2u);
  EXPECT_EQ(ProtoToJson(response)["candidates"][1]["crossing"], "B");
  EXPECT_TRUE(ProtoToJson(v1::ListDatabasesResponse())["databases"].is_array());

  v1::EnrollViewRequest request;
  request.mutable_image()->set_data(std::string(1234, 'x'));
  EXPECT_EQ(ProtoToJson(request)["image"]["data"]["bytes"], 1234);
}

TEST(ModeNameTest, ShortLowercaseNames) {
  EXPECT_EQ(ModeName(v1::RECOGNITION_MODE_PAPER), "paper");
  EXPECT_EQ(ModeName(v1::RECOGNITION_MODE_VERIFIED), "verified");
  EXPECT_EQ(ModeName(v1::RECOGNITION_MODE_UNSPECIFIED), "unspecified");
}

}  // namespace
}  // namespace waymark::cli
