#ifndef WAYMARK_CLIENT_COMMON_PROTO_JSON_H_
#define WAYMARK_CLIENT_COMMON_PROTO_JSON_H_

#include <google/protobuf/message.h>

#include <nlohmann/json.hpp>
#include <string>

#include "waymark/v1/crossing.pb.h"

namespace waymark::cli {

// Any API message as JSON for --json output. Unlike protobuf's own JSON mapping it keeps the
// proto's snake_case field names, writes 64-bit integers as numbers (ids and keypoint counts are
// far below 2^53), writes enums as short lowercase names ("paper"), prints every proto3 scalar
// (zeros included) and leaves out `optional` fields that are unset.
nlohmann::json ProtoToJson(const google::protobuf::Message& message);

// "paper", "verified", or "unspecified".
std::string ModeName(v1::RecognitionMode mode);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_PROTO_JSON_H_
