// Writes MCAP files and a rosbag2 folder with Foxglove's writers (@mcap/core, @foxglove/cdr from
// tests/js), for bags_test. usage: node write_mcap.js OUT_DIR
//   OUT_DIR/ros2.mcap        profile ros2, CDR LaserScan + String, small chunks, statistics and
//                            chunk indexes; some messages logged out of order
//   OUT_DIR/nosummary.mcap   the same messages, unchunked, without a summary section
//   OUT_DIR/ros1.mcap        profile ros1, ros1-encoded String messages with md5sum metadata
//   OUT_DIR/rosbag2/         metadata.yaml + rosbag2_0.mcap (+ _1): a split rosbag2 bag on mcap
//   OUT_DIR/mcap.json        { file: [messages as the reader must give them back, in log-time
//                            order, ties in write order: topic, type, time_ns, data (hex)] }
const fs = require("fs");
const path = require("path");
const { McapWriter } = require("@mcap/core");
const { CdrWriter } = require("@foxglove/cdr");

class FileWritable {
  constructor(file) { this.fd = fs.openSync(file, "w"); this.size = 0n; }
  async write(buffer) { fs.writeSync(this.fd, buffer); this.size += BigInt(buffer.byteLength); }
  position() { return this.size; }
  close() { fs.closeSync(this.fd); }
}

const laserScanDef = "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\n" +
  "float32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\nfloat32 range_min\n" +
  "float32 range_max\nfloat32[] ranges\nfloat32[] intensities\n";

function cdrScan(i, stampNs) {
  const w = new CdrWriter();
  w.int32(Number(stampNs / 1000000000n)).uint32(Number(stampNs % 1000000000n)).string("laser");
  for (const v of [-1.5, 1.5, 0.01, 0, 0.1, 0.1, 30]) w.float32(v);
  const ranges = []; for (let k = 0; k < 301; ++k) ranges.push(1 + 0.01 * ((i * 7 + k) % 100));
  w.float32Array(ranges, true);
  w.float32Array([], true);
  return w.data;
}
function cdrString(text) { const w = new CdrWriter(); w.string(text); return w.data; }
function ros1String(text) {
  const b = Buffer.alloc(4 + text.length); b.writeUInt32LE(text.length, 0); b.write(text, 4); return b;
}

// [topic, type, time_ns, data] in write order.
function ros2Messages() {
  const out = [];
  const base = 1700000000n * 1000000000n;
  for (let i = 0; i < 40; ++i) {
    const t = base + BigInt(i) * 100000000n;
    out.push(["/scan", "sensor_msgs/msg/LaserScan", t, cdrScan(i, t)]);
    if (i % 4 === 0) out.push(["/chatter", "std_msgs/msg/String", t + 1000n, cdrString(`hello ${i}`)]);
  }
  for (let i = 0; i < 3; ++i) {  // late arrivals
    out.push(["/chatter", "std_msgs/msg/String", base + BigInt(i) * 7n, cdrString(`late ${i}`)]);
  }
  return out;
}

async function writeMcap(file, profile, encoding, schemaEncoding, messages, options, extraMetadata) {
  const writable = new FileWritable(file);
  const writer = new McapWriter({ writable, ...options });
  await writer.start({ profile, library: "waymark tests (@mcap/core)" });
  const channels = new Map();
  let sequence = 0;
  for (const [topic, type, time, data] of messages) {
    if (!channels.has(topic)) {
      const schemaId = await writer.registerSchema({
        name: type, encoding: schemaEncoding,
        data: Buffer.from(type.endsWith("LaserScan") ? laserScanDef : "string data\n") });
      const metadata = new Map(extraMetadata ? Object.entries(extraMetadata) : []);
      if (profile === "ros2") metadata.set("offered_qos_profiles", "");
      channels.set(topic, await writer.registerChannel({ topic, schemaId, messageEncoding: encoding, metadata }));
    }
    await writer.addMessage({ channelId: channels.get(topic), sequence: sequence++, logTime: time,
                              publishTime: time, data });
  }
  await writer.end();
  writable.close();
}

function expected(messages, normalize = (t) => t) {
  return messages.map((m, order) => ({ order, topic: m[0], type: normalize(m[1]), time_ns: m[2].toString(),
                                      t: m[2], data: Buffer.from(m[3]).toString("hex") }))
    .sort((a, b) => (a.t < b.t ? -1 : a.t > b.t ? 1 : a.order - b.order))
    .map(({ t, ...rest }) => rest);
}

async function main() {
  const out = process.argv[2];
  const manifest = {};
  const ros2 = ros2Messages();
  await writeMcap(path.join(out, "ros2.mcap"), "ros2", "cdr", "ros2msg", ros2, { chunkSize: 4096 });
  manifest["ros2.mcap"] = expected(ros2);
  await writeMcap(path.join(out, "nosummary.mcap"), "ros2", "cdr", "ros2msg", ros2,
    { useChunks: false, useStatistics: false, useSummaryOffsets: false, useChunkIndex: false,
      useMessageIndex: false, repeatSchemas: false, repeatChannels: false,
      useAttachmentIndex: false, useMetadataIndex: false });
  manifest["nosummary.mcap"] = expected(ros2);
  const ros1 = [];
  for (let i = 0; i < 10; ++i) ros1.push(["/chatter", "std_msgs/String", 1000000000n + BigInt(i), ros1String(`ros1 ${i}`)]);
  await writeMcap(path.join(out, "ros1.mcap"), "ros1", "ros1", "ros1msg", ros1, {},
                  { md5sum: "992ce8a1687cec8c8bd883ec73ca41d1", callerid: "/talker" });
  manifest["ros1.mcap"] = expected(ros1);
  // A split rosbag2 bag on mcap: the first half of the messages (in time) in file 0, the rest in 1.
  const bagDir = path.join(out, "rosbag2");
  fs.mkdirSync(bagDir, { recursive: true });
  const sorted = [...ros2].sort((a, b) => (a[2] < b[2] ? -1 : a[2] > b[2] ? 1 : 0));
  const half = Math.floor(sorted.length / 2);
  await writeMcap(path.join(bagDir, "rosbag2_0.mcap"), "ros2", "cdr", "ros2msg", sorted.slice(0, half), {});
  await writeMcap(path.join(bagDir, "rosbag2_1.mcap"), "ros2", "cdr", "ros2msg", sorted.slice(half), {});
  fs.writeFileSync(path.join(bagDir, "metadata.yaml"), [
    "rosbag2_bagfile_information:", "  version: 5", "  storage_identifier: mcap",
    "  relative_file_paths:", "    - rosbag2_0.mcap", "    - rosbag2_1.mcap",
    `  message_count: ${sorted.length}`, "  compression_format: \"\"", "  compression_mode: \"\"", ""].join("\n"));
  manifest["rosbag2"] = expected(sorted);
  fs.writeFileSync(path.join(out, "mcap.json"), JSON.stringify(manifest));
}

main().catch((e) => { console.error(e); process.exit(1); });
