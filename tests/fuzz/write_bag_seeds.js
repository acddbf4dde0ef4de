// The MCAP seeds of the fuzz target bag_files, written by Foxglove's @mcap/core (tests/js), with
// chunks compressed by the lz4 and zstd command line tools (frame formats, as MCAP stores them).
// Called by write_bag_seeds.py, which wrote the messages first.
// usage: node write_bag_seeds.js MESSAGES_DIR OUT_DIR
//   MESSAGES_DIR/NAME.cdr, NAME.ros1: one serialized message each (ROS's own serializers)
"use strict";
const fs = require("fs");
const path = require("path");
const { execFileSync } = require("child_process");
const jsDir = path.join(__dirname, "..", "js", "node_modules");
const { McapWriter } = require(path.join(jsDir, "@mcap/core"));

const [messagesDir, outDir] = process.argv.slice(2);

class FileWritable {
  constructor(file) { this.fd = fs.openSync(file, "w"); this.size = 0n; }
  async write(buffer) { fs.writeSync(this.fd, buffer); this.size += BigInt(buffer.byteLength); }
  position() { return this.size; }
  close() { fs.closeSync(this.fd); }
}

const compressWith = (tool, name) => (data) => ({
  compression: name,
  compressedData: execFileSync(tool, ["-q", "-c"], { input: Buffer.from(data) }),
});

const read = (name) => fs.readFileSync(path.join(messagesDir, name));
// [topic, ROS 1 style type, message file stem]
const topics = [
  ["/scan", "sensor_msgs/LaserScan", "laserscan"],
  ["/odom", "nav_msgs/Odometry", "odometry"],
  ["/tf", "tf2_msgs/TFMessage", "tf"],
  ["/camera/image_raw", "sensor_msgs/Image", "image_rgb8"],
  ["/camera/image/compressed", "sensor_msgs/CompressedImage", "compressed"],
  ["/camera/camera_info", "sensor_msgs/CameraInfo", "camerainfo"],
];

async function writeMcap(file, profile, options) {
  const ros2 = profile === "ros2";
  const writable = new FileWritable(path.join(outDir, file));
  const writer = new McapWriter({ writable, ...options });
  await writer.start({ profile, library: "waymark fuzz seeds (@mcap/core)" });
  const channels = [];
  for (const [topic, type, stem] of topics) {
    const name = ros2 ? type.replace("/", "/msg/") : type;
    const schemaId = await writer.registerSchema({
      name, encoding: ros2 ? "ros2msg" : "ros1msg", data: Buffer.from(`# ${name}\n`) });
    const metadata = new Map(ros2 ? [["offered_qos_profiles", ""]] : [["md5sum", "0"], ["callerid", "/fuzz"]]);
    channels.push([await writer.registerChannel({
      topic, schemaId, messageEncoding: ros2 ? "cdr" : "ros1", metadata }), read(`${stem}.${ros2 ? "cdr" : "ros1"}`)]);
  }
  const base = 1700000000n * 1000000000n;
  let sequence = 0;
  for (let i = 0; i < 2; ++i) {
    for (const [channelId, data] of channels) {
      const t = base + BigInt(i) * 100000000n + BigInt(channelId);
      await writer.addMessage({ channelId, sequence: sequence++, logTime: t, publishTime: t, data });
    }
  }
  // A late arrival: logged before everything else, written last.
  await writer.addMessage({ channelId: channels[0][0], sequence: sequence++, logTime: base - 5n,
                            publishTime: base - 5n, data: channels[0][1] });
  await writer.end();
  writable.close();
}

async function main() {
  // Small chunks so that each file has several, with chunk indexes and statistics.
  await writeMcap("mcap-ros2-chunks-none.mcap", "ros2", { chunkSize: 1024 });
  await writeMcap("mcap-ros2-chunks-lz4.mcap", "ros2",
                  { chunkSize: 1024, compressChunk: compressWith("lz4", "lz4") });
  await writeMcap("mcap-ros2-chunks-zstd.mcap", "ros2",
                  { chunkSize: 1024, compressChunk: compressWith("zstd", "zstd") });
  await writeMcap("mcap-ros1-unchunked-no-summary.mcap", "ros1",
    { useChunks: false, useStatistics: false, useSummaryOffsets: false, useChunkIndex: false,
      useMessageIndex: false, repeatSchemas: false, repeatChannels: false,
      useAttachmentIndex: false, useMetadataIndex: false });
  // A recording cut short: the zstd file without its last 100 bytes (footer and summary offsets).
  const whole = fs.readFileSync(path.join(outDir, "mcap-ros2-chunks-zstd.mcap"));
  fs.writeFileSync(path.join(outDir, "mcap-ros2-cut-before-footer.mcap"),
                   whole.subarray(0, whole.length - 100));
}

main().catch((e) => { console.error(e); process.exit(1); });
