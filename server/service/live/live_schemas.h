#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_SCHEMAS_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_SCHEMAS_H_

// The JSON Schemas the live view advertises its channels with (Foxglove WebSocket protocol,
// encoding "json", schemaEncoding "jsonschema"). The foxglove.* ones follow the field lists of
// foxglove/schemas (schemas/jsonschema/*.json), so Foxglove's panels show them without a plugin;
// the waymark.* ones describe what the session answers already carry (slam.proto, crossing.proto)
// and nothing else. docs/live-view.md lists them.

#include <string>

#include "server/service/live/folder.h"

namespace waymark::service::live {

// A channel's kind: its topic suffix, schema name and schema.
struct ChannelSchema {
  const char* suffix;       // "pose": the topic is /sessions/<id>/pose
  const char* schema_name;  // "foxglove.PoseInFrame"
  std::string schema;       // the JSON Schema, serialized
};

const ChannelSchema& PoseSchema();           // foxglove.PoseInFrame
const ChannelSchema& ScanSchema();           // foxglove.LaserScan
const ChannelSchema& GridSchema();           // foxglove.Grid (data: base64)
const ChannelSchema& TrajectorySchema();     // foxglove.PosesInFrame
const ChannelSchema& LoopClosuresSchema();   // waymark.LoopClosures
const ChannelSchema& ConfidenceSchema();     // waymark.Confidence
const ChannelSchema& VisualFrameSchema();    // waymark.VisualFrame
const ChannelSchema& RecognitionSchema();    // waymark.Recognition (server-wide /recognitions)
const ChannelSchema& SessionsSchema();       // waymark.Sessions (server-wide /sessions)

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_SCHEMAS_H_
