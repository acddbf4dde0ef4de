// The CARMEN slice carmen_to_bag.py wrote, as an MCAP file of the ros2 profile with CDR messages,
// written by Foxglove's libraries (@mcap/core's McapWriter, @foxglove/rosmsg2-serialization over
// @foxglove/cdr, ROS 2 Humble definitions from @foxglove/rosmsg-msgs-common; pinned in
// tests/js/package-lock.json), for tests/ros/bag_replay_test.cc.
//
//   node carmen_to_mcap.js SLICE_LOG MOUNT_TXT OUT.mcap
//
// The same topics, frames, stamps and beam layout as slice.bag (see carmen_to_bag.py): /scan,
// /odom, /tf per FLASER line, /tf_static once; log time = header stamp - 15 s.
"use strict";
const fs = require("fs");
const path = require("path");
const jsDir = path.join(__dirname, "..", "js", "node_modules");
const { McapWriter } = require(path.join(jsDir, "@mcap/core"));
const { MessageWriter } = require(path.join(jsDir, "@foxglove/rosmsg2-serialization"));
const { ros2humble } = require(path.join(jsDir, "@foxglove/rosmsg-msgs-common"));

const [slicePath, mountPath, outPath] = process.argv.slice(2);

// `type` and what it uses, root first (MessageWriter's input), and as ros2msg text (the schema).
function definitionsOf(type) {
  const all = [];
  const seen = new Set();
  const visit = (name) => {
    if (seen.has(name)) return;
    seen.add(name);
    all.push(ros2humble[name]);
    for (const field of ros2humble[name].definitions) if (field.isComplex) visit(field.type);
  };
  visit(type);
  return all;
}
function schemaText(definitions) {
  const text = (def) =>
    def.definitions
      .filter((f) => !f.isConstant)
      .map((f) => `${f.type}${f.isArray ? `[${f.arrayLength ?? ""}]` : ""} ${f.name}`)
      .join("\n");
  return [text(definitions[0])]
    .concat(definitions.slice(1).map((d) => `${"=".repeat(80)}\nMSG: ${d.name}\n${text(d)}`))
    .join("\n");
}

function flaserIncrement(n) {
  if (n === 180 || n === 181) return Math.PI / 180;
  if (n === 360 || n === 361) return Math.PI / 360;
  return Math.PI / n;
}

// Seconds (as the log prints them) into builtin_interfaces/Time, rounded to the nanosecond like
// carmen_to_bag.py.
function stampOf(seconds) {
  let sec = Math.floor(seconds);
  let nanosec = Math.round((seconds - sec) * 1e9);
  if (nanosec >= 1e9) {
    sec += 1;
    nanosec -= 1e9;
  }
  return { sec, nanosec };
}
const nsOf = (stamp) => BigInt(stamp.sec) * 1000000000n + BigInt(stamp.nanosec);
const yawQuaternion = (yaw) => ({ x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) });

async function main() {
  const mount = fs.readFileSync(mountPath, "utf8").trim().split(/\s+/).map(Number);
  const lasers = [];
  for (const line of fs.readFileSync(slicePath, "utf8").split("\n")) {
    const f = line.trim().split(/\s+/);
    if (f[0] !== "FLASER") continue;
    const n = Number(f[1]);
    lasers.push({
      ranges: f.slice(2, 2 + n).map(Number),
      odom: f.slice(5 + n, 8 + n).map(Number),
      stamp: Number(f[8 + n]),
    });
  }

  const chunks = [];
  let position = 0n;
  const writable = {
    write: async (buffer) => {
      chunks.push(Buffer.from(buffer));
      position += BigInt(buffer.byteLength);
    },
    position: () => position,
  };
  const writer = new McapWriter({ writable, chunkSize: 64 * 1024 });
  await writer.start({ profile: "ros2", library: "waymark tests/ros/carmen_to_mcap.js" });
  const channels = {};
  const writers = {};
  for (const [topic, type] of [["/scan", "sensor_msgs/LaserScan"], ["/odom", "nav_msgs/Odometry"],
                               ["/tf", "tf2_msgs/TFMessage"], ["/tf_static", "tf2_msgs/TFMessage"]]) {
    const definitions = definitionsOf(type);
    const schemaId = await writer.registerSchema({
      name: type.replace("/", "/msg/"),
      encoding: "ros2msg",
      data: new TextEncoder().encode(schemaText(definitions)),
    });
    channels[topic] = await writer.registerChannel({
      schemaId,
      topic,
      messageEncoding: "cdr",
      metadata: new Map([["offered_qos_profiles", ""]]),
    });
    writers[topic] = new MessageWriter(definitions);
  }
  let sequence = 0;
  const add = async (topic, stamp, message) => {
    const logTime = nsOf(stamp) - 15000000000n;
    await writer.addMessage({
      channelId: channels[topic],
      sequence: sequence++,
      logTime,
      publishTime: logTime,
      data: writers[topic].writeMessage(message),
    });
  };

  const start = stampOf(lasers[0].stamp);
  await add("/tf_static", start, {
    transforms: [{
      header: { stamp: start, frame_id: "base_link" },
      child_frame_id: "laser",
      transform: { translation: { x: mount[0], y: mount[1], z: 0 }, rotation: yawQuaternion(mount[2]) },
    }],
  });
  for (const laser of lasers) {
    const stamp = stampOf(laser.stamp);
    const orientation = yawQuaternion(laser.odom[2]);
    const position3 = { x: laser.odom[0], y: laser.odom[1], z: 0 };
    await add("/odom", stamp, {
      header: { stamp, frame_id: "odom" },
      child_frame_id: "base_link",
      pose: { pose: { position: position3, orientation }, covariance: new Array(36).fill(0) },
      twist: {
        twist: { linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } },
        covariance: new Array(36).fill(0),
      },
    });
    await add("/tf", stamp, {
      transforms: [{
        header: { stamp, frame_id: "odom" },
        child_frame_id: "base_link",
        transform: { translation: position3, rotation: orientation },
      }],
    });
    const increment = flaserIncrement(laser.ranges.length);
    await add("/scan", stamp, {
      header: { stamp, frame_id: "laser" },
      angle_min: -Math.PI / 2,
      angle_max: -Math.PI / 2 + (laser.ranges.length - 1) * increment,
      angle_increment: increment,
      time_increment: 0,
      scan_time: 0,
      range_min: 0,
      range_max: Infinity,
      ranges: new Float32Array(laser.ranges),
      intensities: new Float32Array(0),
    });
  }
  await writer.end();
  fs.writeFileSync(outPath, Buffer.concat(chunks));
}

main().catch((error) => {
  console.error(error);
  process.exit(1);
});
