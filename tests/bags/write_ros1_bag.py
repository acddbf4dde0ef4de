#!/usr/bin/python3
"""Writes ROS 1 bags with ROS's own writer (Debian's python3-rosbag), for bags_test.

usage: write_ros1_bag.py OUT_DIR
Writes OUT_DIR/{none,bz2,lz4}.bag holding the same messages (small chunks, so there are many;
some messages written out of time order, so chunks overlap in time) and OUT_DIR/ros1.json: the
messages as the reader must give them back (topic, type, log time, serialized bytes in hex), in
log-time order, ties in write order.
"""
import io
import json
import sys

import genpy
import rosbag
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage


def messages():
    """(topic, message, time) in write order."""
    out = []
    for i in range(60):
        t = genpy.Time(1700000000 + i // 10, (i % 10) * 100000000)
        scan = LaserScan()
        scan.header.stamp = t
        scan.header.frame_id = "laser"
        scan.angle_min, scan.angle_max, scan.angle_increment = -1.5, 1.5, 0.01
        scan.range_min, scan.range_max = 0.1, 30.0
        scan.ranges = [1.0 + 0.01 * ((i * 7 + k) % 100) for k in range(301)]
        out.append(("/scan", scan, t))
        odom = Odometry()
        odom.header.stamp = t
        odom.header.frame_id = "odom"
        odom.child_frame_id = "base_link"
        odom.pose.pose.position.x = 0.1 * i
        odom.pose.pose.orientation.w = 1.0
        out.append(("/odom", odom, t + genpy.Duration(0, 5000000)))
        if i % 5 == 0:
            tf = TFMessage()
            transform = TransformStamped()
            transform.header.stamp = t
            transform.header.frame_id = "odom"
            transform.child_frame_id = "base_link"
            transform.transform.translation.x = 0.1 * i
            transform.transform.rotation.w = 1.0
            tf.transforms.append(transform)
            out.append(("/tf", tf, t))
    # Late arrivals: logged after later messages were written, stamped earlier.
    for i in range(3):
        out.append(("/chatter", String(data="late %d" % i), genpy.Time(1700000000, 50000000 * i)))
    return out


def main():
    out_dir = sys.argv[1]
    written = messages()
    for name, compression in (("none", rosbag.Compression.NONE), ("bz2", rosbag.Compression.BZ2),
                              ("lz4", rosbag.Compression.LZ4)):
        with rosbag.Bag("%s/%s.bag" % (out_dir, name), "w", compression=compression,
                        chunk_threshold=16 * 1024) as bag:
            for topic, message, t in written:
                bag.write(topic, message, t)
    expected = []
    for order, (topic, message, t) in enumerate(written):
        buffer = io.BytesIO()
        message.serialize(buffer)
        expected.append({"order": order, "topic": topic, "type": message._type,
                         "time_ns": t.to_nsec(), "data": buffer.getvalue().hex()})
    expected.sort(key=lambda m: (m["time_ns"], m["order"]))
    with open("%s/ros1.json" % out_dir, "w") as f:
        json.dump(expected, f)


if __name__ == "__main__":
    main()
