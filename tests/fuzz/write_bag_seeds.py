#!/usr/bin/python3
"""Writes the seed corpora of the fuzz targets bag_files and ros_messages (tests/fuzz/bag_targets.cc)
with writers that are not ours: Debian's python3-rosbag and genpy (ROS 1 bags and messages),
Foxglove's @mcap/core and ROS 2 serializer from tests/js (MCAP files, CDR messages; through
write_bag_seeds.js), Python's sqlite3 on rosbag2's schemas (.db3), the zstd, lz4 and bzip2 command
line tools for compressed chunks. Nothing of ../shared is copied. Each file is a few KB (the
corpora are in the repository); corpus/bag_files/README.md and corpus/ros_messages/README.md say
what each one is.

usage: /usr/bin/python3 tests/fuzz/write_bag_seeds.py      (rewrites the seed files in place)
"""
import io
import os
import shutil
import sqlite3
import struct
import subprocess
import sys
import tempfile

import genpy
import rosbag
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, LaserScan
from tf2_msgs.msg import TFMessage

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
BAGS = os.path.join(HERE, "corpus", "bag_files")
MESSAGES = os.path.join(HERE, "corpus", "ros_messages")

# ros_messages' input: [type selector][encoding][message]; bag_targets.cc reads them the same way.
TYPES = ["laserscan", "odometry", "tf", "image", "compressed", "camerainfo"]
ROS1, CDR = 0, 1


def ros1_messages(t0):
    """(topic, message, time): a short recording with every type the decoders read."""
    out = []
    for i in range(4):
        t = genpy.Time(t0 + i // 2, (i % 2) * 500000000)
        scan = LaserScan()
        scan.header.seq = i
        scan.header.stamp = t
        scan.header.frame_id = "laser"
        scan.angle_min, scan.angle_max, scan.angle_increment = -1.0, 1.0, 0.25
        scan.range_min, scan.range_max = 0.1, 10.0
        scan.ranges = [1.0 + 0.1 * ((i + k) % 5) for k in range(9)]
        scan.intensities = [100.0] * (9 if i % 2 else 0)
        out.append(("/scan", scan, t))
        odom = Odometry()
        odom.header.stamp = t
        odom.header.frame_id = "odom"
        odom.child_frame_id = "base_link"
        odom.pose.pose.position.x = 0.1 * i
        odom.pose.pose.orientation.z = 0.0499792
        odom.pose.pose.orientation.w = 0.99875
        out.append(("/odom", odom, t + genpy.Duration(0, 1000)))
    tf = TFMessage()
    for parent, child in (("odom", "base_link"), ("base_link", "laser")):
        transform = TransformStamped()
        transform.header.stamp = genpy.Time(t0, 0)
        transform.header.frame_id = parent
        transform.child_frame_id = child
        transform.transform.translation.x = 0.2
        transform.transform.rotation.w = 1.0
        tf.transforms.append(transform)
    out.append(("/tf", tf, genpy.Time(t0, 0)))
    image = Image()
    image.header.stamp = genpy.Time(t0, 100)
    image.header.frame_id = "camera"
    image.height, image.width, image.encoding, image.step = 2, 3, "mono8", 3
    image.data = bytes(range(6))
    out.append(("/camera/image_raw", image, genpy.Time(t0, 100)))
    compressed = CompressedImage()
    compressed.header.stamp = genpy.Time(t0, 200)
    compressed.header.frame_id = "camera"
    compressed.format = "png"
    compressed.data = b"\x89PNG\r\n\x1a\n not a whole png"
    out.append(("/camera/image/compressed", compressed, genpy.Time(t0, 200)))
    info = CameraInfo()
    info.header.stamp = genpy.Time(t0, 300)
    info.header.frame_id = "camera"
    info.height, info.width, info.distortion_model = 480, 640, "plumb_bob"
    info.D = [0.1, -0.2, 0.0, 0.0, 0.0]
    info.K = [500.0, 0, 320.0, 0, 500.0, 240.0, 0, 0, 1.0]
    info.R = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    info.P = [500.0, 0, 320.0, 0, 0, 500.0, 240.0, 0, 0, 0, 1.0, 0]
    out.append(("/camera/camera_info", info, genpy.Time(t0, 300)))
    return out


def short_definition(message):
    """The message as a subclass whose definition text is one line: rosbag writes a connection's
    full definition (CameraInfo's is 8 KB) twice per bag; the readers only list it."""
    cls = type(message)
    short = type(cls.__name__, (cls,), {"_full_text": "# %s (definition shortened)\n" % cls._type})
    copy = short()
    for slot in cls.__slots__:
        setattr(copy, slot, getattr(message, slot))
    return copy


def write_ros1_bags(scratch):
    written = [(topic, short_definition(m), t) for topic, m, t in ros1_messages(1700000000)]
    for name, compression in (("none", rosbag.Compression.NONE), ("bz2", rosbag.Compression.BZ2),
                              ("lz4", rosbag.Compression.LZ4)):
        path = os.path.join(BAGS, "ros1-%s.bag" % name)
        # Small chunks: several per bag, so the index lists more than one.
        with rosbag.Bag(path, "w", compression=compression, chunk_threshold=1024) as bag:
            for topic, message, t in written:
                bag.write(topic, message, t)
    # Chunks out of time order (a late message in the last chunk), then cut before its index: a
    # recording that was not closed, read by scanning its records.
    path = os.path.join(scratch, "unindexed.bag")
    with rosbag.Bag(path, "w", chunk_threshold=512) as bag:
        for topic, message, t in written:
            bag.write(topic, message, t)
        bag.write("/scan", written[0][1], genpy.Time(1699999999, 0))
    with open(path, "rb") as f:
        data = f.read()
    # The bag header record's index_pos field (uint64) says where the index starts.
    at = data.index(b"index_pos=") + len(b"index_pos=")
    index_pos = struct.unpack("<Q", data[at:at + 8])[0]
    # rosbag writes index_pos 0 when it opens a bag and the real offset when it closes it.
    data = data[:at] + struct.pack("<Q", 0) + data[at + 8:index_pos]
    with open(os.path.join(BAGS, "ros1-unindexed-unsorted.bag"), "wb") as f:
        f.write(data)


def cdr(parts):
    """Little-endian CDR of [(kind, value)], aligned from after the encapsulation header."""
    out = bytearray()

    def align(n):
        out.extend(b"\0" * ((n - len(out) % n) % n))

    for kind, value in parts:
        if kind == "u32" or kind == "i32":
            align(4)
            out += struct.pack("<I" if kind == "u32" else "<i", value)
        elif kind == "string":
            align(4)
            body = value.encode() + b"\0"
            out += struct.pack("<I", len(body)) + body
        elif kind == "bytes":
            align(4)
            out += struct.pack("<I", len(value)) + value
    return b"\x00\x01\x00\x00" + bytes(out)


def write_messages(msgs):
    """The ros_messages seeds: ROS's serializers' bytes with the selector and encoding bytes."""
    pairs = {  # seed name -> (type index, file written by tests/ros/write_*_messages)
        "laserscan": ("laserscan", "laserscan"), "odometry": ("odometry", "odometry"),
        "tf": ("tf", "tf"), "image-rgb8": ("image", "image_rgb8"),
        "image-yuv422": ("image", "image_yuv422"), "compressed": ("compressed", "compressed"),
        "camerainfo": ("camerainfo", "camerainfo"),
    }
    for seed, (kind, stem) in pairs.items():
        for encoding, extension in ((ROS1, "ros1"), (CDR, "cdr")):
            source = os.path.join(msgs, "%s.%s" % (stem, extension))
            if not os.path.exists(source):
                continue
            with open(source, "rb") as f:
                body = f.read()
            with open(os.path.join(MESSAGES, "%s-%s" % (seed, extension)), "wb") as f:
                f.write(bytes([TYPES.index(kind), encoding]) + body)
    with open(os.path.join(msgs, "laserscan_be.cdr"), "rb") as f:
        body = f.read()
    with open(os.path.join(MESSAGES, "laserscan-cdr-big-endian"), "wb") as f:
        f.write(bytes([TYPES.index("laserscan"), CDR]) + body)
    # CompressedImage in CDR (Foxglove's writer script has none): header, format, data.
    compressed = cdr([("i32", 11), ("u32", 0), ("string", "camera"), ("string", "png"),
                      ("bytes", b"\x89PNG not really")])
    with open(os.path.join(msgs, "compressed.cdr"), "wb") as f:
        f.write(compressed)
    with open(os.path.join(MESSAGES, "compressed-cdr"), "wb") as f:
        f.write(bytes([TYPES.index("compressed"), CDR]) + compressed)


DB3_OLD = [
    "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
    "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL)",
    "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
    "timestamp INTEGER NOT NULL, data BLOB NOT NULL)",
]
DB3_NEW = [
    "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL)",
    "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
    "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL, "
    "type_description_hash TEXT NOT NULL)",
    "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, "
    "encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, "
    "type_description_hash TEXT NOT NULL)",
    "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
    "timestamp INTEGER NOT NULL, data BLOB NOT NULL)",
]


def write_db3(msgs):
    topics = [(1, "/scan", "sensor_msgs/msg/LaserScan", "laserscan"),
              (2, "/odom", "nav_msgs/msg/Odometry", "odometry"),
              (3, "/tf", "tf2_msgs/msg/TFMessage", "tf"),
              (4, "/camera/camera_info", "sensor_msgs/msg/CameraInfo", "camerainfo"),
              (5, "/camera/image/compressed", "sensor_msgs/msg/CompressedImage", "compressed")]
    payload = {}
    for _, _, _, stem in topics:
        with open(os.path.join(msgs, stem + ".cdr"), "rb") as f:
            payload[stem] = f.read()
    base = 1700000000 * 10**9
    rows = [(t[0], base + i * 10**8 + t[0], payload[t[3]]) for i in range(2) for t in topics]
    rows.append((1, base - 5, payload["laserscan"]))  # written last, logged first
    for name, schema, zstd in (("old-schema", DB3_OLD, False), ("new-schema", DB3_NEW, False),
                               ("zstd-per-message", DB3_OLD, True)):
        path = os.path.join(BAGS, "rosbag2-%s.db3" % name)
        if os.path.exists(path):
            os.remove(path)
        db = sqlite3.connect(path)
        db.execute("PRAGMA page_size = 512")  # the smallest pages: a file of a few KB
        for statement in schema:
            db.execute(statement)
        for topic_id, topic, type_name, _ in topics:
            if schema is DB3_NEW:
                db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '', 'RIHS01_00')",
                           (topic_id, topic, type_name))
            else:
                db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", (topic_id, topic, type_name))
        if schema is DB3_NEW:
            db.execute("INSERT INTO schema VALUES (4, 'jazzy')")
            db.execute("INSERT INTO message_definitions (topic_type, encoding, "
                       "encoded_message_definition, type_description_hash) VALUES "
                       "('sensor_msgs/msg/LaserScan', 'ros2msg', 'float32[] ranges', '')")
        for topic_id, timestamp, data in rows:
            if zstd:
                data = subprocess.run(["zstd", "-q", "-c"], input=data, stdout=subprocess.PIPE,
                                      check=True).stdout
            db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                       (topic_id, timestamp, data))
        db.commit()
        db.execute("VACUUM")
        db.close()
    # metadata.yaml as the first bytes of a file: opened as a rosbag2 bag's metadata, whose listed
    # storage file is missing next to it (or, when the fuzzer names it, the input itself).
    with open(os.path.join(BAGS, "rosbag2-metadata.yaml"), "w") as f:
        f.write("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                "  relative_file_paths:\n    - input.db3\n  message_count: 11\n"
                "  compression_format: zstd\n  compression_mode: MESSAGE\n")


def main():
    for folder in (BAGS, MESSAGES):
        os.makedirs(folder, exist_ok=True)
        for name in os.listdir(folder):  # the seeds written here before; regression inputs stay
            if name.startswith(("ros1-", "rosbag2-", "mcap-")) or name.endswith(("-ros1", "-cdr")) \
                    or name == "laserscan-cdr-big-endian":
                os.remove(os.path.join(folder, name))
    scratch = tempfile.mkdtemp(prefix="waymark-seeds-")
    try:
        msgs = os.path.join(scratch, "messages")
        os.makedirs(msgs)
        subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "tests/ros/write_ros1_messages.py"),
                        msgs], check=True)
        subprocess.run(["node", os.path.join(ROOT, "tests/ros/write_cdr_messages.js"), msgs],
                       check=True)
        write_messages(msgs)
        write_ros1_bags(scratch)
        write_db3(msgs)
        subprocess.run(["node", os.path.join(HERE, "write_bag_seeds.js"), msgs, BAGS], check=True)
    finally:
        shutil.rmtree(scratch)
    for folder in (BAGS, MESSAGES):
        for name in sorted(os.listdir(folder)):
            size = os.path.getsize(os.path.join(folder, name))
            print("%7d %s/%s" % (size, os.path.basename(folder), name))
            if size >= 20 * 1024:
                sys.exit("%s is %d bytes: seeds stay under 20 KB" % (name, size))


if __name__ == "__main__":
    main()
