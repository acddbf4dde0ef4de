#!/usr/bin/python3
"""The first N laser lines of a CARMEN log as a CARMEN slice and as a ROS 1 bag written by Debian's
rosbag (python3-rosbag), for the test that a bag replay gives the CARMEN replay's trajectory
(tests/ros/bag_replay_test.cc).

  carmen_to_bag.py LOG OUT_DIR N MOUNT_X MOUNT_Y MOUNT_THETA

Writes into OUT_DIR:
  slice.log   the log's lines up to its N-th FLASER line (plain text), each FLASER's laser pose
              rewritten to odom (+) mount, so the CARMEN replay finds the laser mounted there;
  mount.txt   that mounting as the CARMEN replay computes it from the first line as written
              (inv(odom) (+) laser, in double), for carmen_to_mcap.js;
  slice.bag   per FLASER line, at its stamp: /scan sensor_msgs/LaserScan (frame "laser", the
              FLASER beam layout: first beam at -90 deg, 1 deg for 180/181 beams, 0.5 deg for
              360/361, pi/n otherwise; range_max +inf, so there is no no-return range, as FLASER
              has none), /odom nav_msgs/Odometry (odom -> base_link) and /tf (the same pose);
              /tf_static base_link -> laser (the mounting) once at the start. The record time is
              the stamp minus 15 s: the replay must go by header stamps, as real bags need.
Only FLASER lines are converted (ROBOTLASER1 is refused)."""
import bz2
import gzip
import math
import sys

import genpy
import rosbag
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage


def open_log(path):
    with open(path, "rb") as f:
        magic = f.read(3)
    if magic[:2] == b"\x1f\x8b":
        return gzip.open(path, "rt")
    if magic == b"BZh":
        return bz2.open(path, "rt")
    return open(path, "r")


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], normalize(a[2] + b[2]))


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], normalize(-a[2]))


def normalize(angle):
    # client/eval/relations_metric.cc's NormalizeAngle: fmod, then into (-pi, pi].
    angle = math.fmod(angle, 2 * math.pi)
    if angle <= -math.pi:
        angle += 2 * math.pi
    if angle > math.pi:
        angle -= 2 * math.pi
    return angle


def flaser_increment(n):
    if n in (180, 181):
        return math.pi / 180
    if n in (360, 361):
        return math.pi / 360
    return math.pi / n


def stamp_of(seconds):
    secs = int(math.floor(seconds))
    nsecs = int(round((seconds - secs) * 1e9))
    if nsecs >= 1000000000:
        secs, nsecs = secs + 1, nsecs - 1000000000
    return genpy.Time(secs, nsecs)


def quaternion(msg_q, yaw):
    msg_q.z = math.sin(yaw / 2)
    msg_q.w = math.cos(yaw / 2)


def main(log, out_dir, count, mount):
    lines = []
    lasers = []  # (stamp, ranges, odom pose)
    with open_log(log) as f:
        for line in f:
            fields = line.split()
            if fields and fields[0] == "ROBOTLASER1":
                sys.exit("carmen_to_bag.py converts FLASER lines only")
            if not fields or fields[0] != "FLASER":
                lines.append(line)
                continue
            n = int(fields[1])
            ranges = fields[2:2 + n]
            odom = tuple(float(v) for v in fields[5 + n:8 + n])
            laser = compose(odom, mount)
            rest = fields[8 + n:]
            written = ["FLASER", str(n)] + ranges + ["%.6f" % v for v in laser] + \
                fields[5 + n:8 + n] + rest
            lines.append(" ".join(written) + "\n")
            lasers.append((float(rest[0]), [float(r) for r in ranges], odom,
                           tuple(float("%.6f" % v) for v in laser)))
            if len(lasers) == count:
                break
    with open(f"{out_dir}/slice.log", "w") as f:
        f.writelines(lines)
    first = lasers[0]
    written_mount = compose(inverse(first[2]), first[3])
    with open(f"{out_dir}/mount.txt", "w") as f:
        f.write("%r %r %r\n" % written_mount)

    bag = rosbag.Bag(f"{out_dir}/slice.bag", "w")
    try:
        start = stamp_of(lasers[0][0])
        static = TFMessage()
        t = TransformStamped()
        t.header.stamp = start
        t.header.frame_id = "base_link"
        t.child_frame_id = "laser"
        t.transform.translation.x = written_mount[0]
        t.transform.translation.y = written_mount[1]
        quaternion(t.transform.rotation, written_mount[2])
        static.transforms.append(t)
        bag.write("/tf_static", static, start - genpy.Duration(15))
        for seq, (stamp_s, ranges, odom, _) in enumerate(lasers):
            stamp = stamp_of(stamp_s)
            record = stamp - genpy.Duration(15)
            odometry = Odometry()
            odometry.header.seq = seq
            odometry.header.stamp = stamp
            odometry.header.frame_id = "odom"
            odometry.child_frame_id = "base_link"
            odometry.pose.pose.position.x = odom[0]
            odometry.pose.pose.position.y = odom[1]
            quaternion(odometry.pose.pose.orientation, odom[2])
            bag.write("/odom", odometry, record)
            tf = TFMessage()
            t = TransformStamped()
            t.header = odometry.header
            t.child_frame_id = "base_link"
            t.transform.translation.x = odom[0]
            t.transform.translation.y = odom[1]
            t.transform.rotation = odometry.pose.pose.orientation
            tf.transforms.append(t)
            bag.write("/tf", tf, record)
            scan = LaserScan()
            scan.header.seq = seq
            scan.header.stamp = stamp
            scan.header.frame_id = "laser"
            scan.angle_min = -math.pi / 2
            scan.angle_increment = flaser_increment(len(ranges))
            scan.angle_max = scan.angle_min + (len(ranges) - 1) * scan.angle_increment
            scan.range_min = 0.0
            scan.range_max = float("inf")
            scan.ranges = ranges
            bag.write("/scan", scan, record)
    finally:
        bag.close()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]),
         (float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6])))
