// Writes one CDR serialized message per file into OUT_DIR with Foxglove's ROS 2 serializer
// (@foxglove/rosmsg2-serialization over @foxglove/cdr, with the ROS 2 Humble definitions of
// @foxglove/rosmsg-msgs-common; all three pinned in tests/js/package-lock.json): the bytes
// tests/ros/ros_messages_test.cc decodes, written by a writer that is not ours. The values match
// write_ros1_messages.py's (ROS 2 headers have no seq); keep them in step with the test.
// Also a big-endian LaserScan (CdrWriter with kind CDR_BE, fields in the message's order).
"use strict";
const fs = require("fs");
const path = require("path");
const jsDir = path.join(__dirname, "..", "js", "node_modules");
const { MessageWriter } = require(path.join(jsDir, "@foxglove/rosmsg2-serialization"));
const { CdrWriter, EncapsulationKind } = require(path.join(jsDir, "@foxglove/cdr"));
const { ros2humble } = require(path.join(jsDir, "@foxglove/rosmsg-msgs-common"));

const outDir = process.argv[2];

// The definition of `type` and everything it uses, root first.
function definitionsOf(type) {
  const all = [];
  const seen = new Set();
  const visit = (name) => {
    if (seen.has(name)) return;
    seen.add(name);
    const def = ros2humble[name];
    if (!def) throw new Error(`no definition of ${name}`);
    all.push(def);
    for (const field of def.definitions) if (field.isComplex) visit(field.type);
  };
  visit(type);
  return all;
}

function write(name, type, message) {
  const bytes = new MessageWriter(definitionsOf(type)).writeMessage(message);
  fs.writeFileSync(path.join(outDir, `${name}.cdr`), bytes);
}

const header = (sec, nanosec, frame_id) => ({ stamp: { sec, nanosec }, frame_id });

const scan = {
  header: header(1518520222, 271470000, "base_laser"),
  angle_min: -2.356194496154785,
  angle_max: 2.356194496154785,
  angle_increment: 0.006135923322290182,
  time_increment: 0.0001,
  scan_time: 0.1,
  range_min: 0.02,
  range_max: 5.6,
  ranges: new Float32Array([1.0, 2.5, Infinity, 0.01, 5.5]),
  intensities: new Float32Array([100.0, 200.0]),
};
write("laserscan", "sensor_msgs/LaserScan", scan);

write("odometry", "nav_msgs/Odometry", {
  header: header(60, 200000000, "odom"),
  child_frame_id: "",
  pose: {
    pose: {
      position: { x: 1.5, y: -2.25, z: 0 },
      orientation: { x: 0, y: 0, z: 0.38268343236508984, w: 0.9238795325112867 },
    },
    covariance: Array.from({ length: 36 }, (_, i) => i),
  },
  twist: {
    twist: { linear: { x: 0.3, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } },
    covariance: new Array(36).fill(0),
  },
});

const transform = (parent, child, x) => ({
  header: header(100, 5, parent),
  child_frame_id: child,
  transform: { translation: { x, y: 0, z: 0 }, rotation: { x: 0, y: 0, z: 0, w: 1 } },
});
write("tf", "tf2_msgs/TFMessage", {
  transforms: [transform("odom", "base_link", 0.5), transform("base_link", "laser", 0.2)],
});

const image = {
  header: header(10, 0, "camera"),
  height: 2,
  width: 3,
  encoding: "rgb8",
  is_bigendian: 0,
  step: 9,
  data: Uint8Array.from({ length: 18 }, (_, i) => i),
};
write("image_rgb8", "sensor_msgs/Image", image);

write("camerainfo", "sensor_msgs/CameraInfo", {
  header: header(12, 0, "camera"),
  height: 960,
  width: 1280,
  distortion_model: "plumb_bob",
  d: [0.1, -0.2, 0.001, 0.002, 0.0],
  k: [1000.0, 0, 640.0, 0, 1001.0, 480.0, 0, 0, 1.0],
  r: [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0],
  p: [1000.0, 0, 640.0, 0, 0, 1001.0, 480.0, 0, 0, 0, 1.0, 0],
  binning_x: 0,
  binning_y: 0,
  roi: { x_offset: 0, y_offset: 0, height: 0, width: 0, do_rectify: false },
});

// Big-endian: the same scan through CdrWriter directly.
const be = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
be.int32(scan.header.stamp.sec).uint32(scan.header.stamp.nanosec).string(scan.header.frame_id);
for (const f of ["angle_min", "angle_max", "angle_increment", "time_increment", "scan_time",
                 "range_min", "range_max"]) {
  be.float32(scan[f]);
}
be.float32Array(scan.ranges, true).float32Array(scan.intensities, true);
fs.writeFileSync(path.join(outDir, "laserscan_be.cdr"), be.data);
