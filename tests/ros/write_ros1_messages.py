#!/usr/bin/python3
"""Writes one ROS 1 serialized message per file into OUT_DIR with Debian's genpy message classes
(python3-sensor-msgs, python3-nav-msgs, python3-tf2-msgs): the bytes tests/ros/ros_messages_test.cc
decodes, written by ROS's own serializer rather than ours. The values are the ones the test
expects; keep both in step."""
import io
import sys

import genpy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, LaserScan
from tf2_msgs.msg import TFMessage


def write(out_dir, name, msg):
    buffer = io.BytesIO()
    msg.serialize(buffer)
    with open(f"{out_dir}/{name}.ros1", "wb") as f:
        f.write(buffer.getvalue())


def header(h, seq, sec, nsec, frame):
    h.seq = seq
    h.stamp = genpy.Time(sec, nsec)
    h.frame_id = frame


def main(out_dir):
    scan = LaserScan()
    header(scan.header, 7, 1518520222, 271470000, "/base_laser")
    scan.angle_min = -2.356194496154785
    scan.angle_max = 2.356194496154785
    scan.angle_increment = 0.006135923322290182
    scan.time_increment = 0.0001
    scan.scan_time = 0.1
    scan.range_min = 0.02
    scan.range_max = 5.6
    scan.ranges = [1.0, 2.5, float("inf"), 0.01, 5.5]
    scan.intensities = [100.0, 200.0]
    write(out_dir, "laserscan", scan)

    odom = Odometry()
    header(odom.header, 3, 60, 200000000, "odom")
    odom.child_frame_id = ""
    odom.pose.pose.position.x = 1.5
    odom.pose.pose.position.y = -2.25
    odom.pose.pose.orientation.z = 0.38268343236508984  # yaw 45 deg
    odom.pose.pose.orientation.w = 0.9238795325112867
    odom.pose.covariance = [float(i) for i in range(36)]
    odom.twist.twist.linear.x = 0.3
    write(out_dir, "odometry", odom)

    tf = TFMessage()
    for child, x in (("base_link", 0.5), ("laser", 0.2)):
        t = TransformStamped()
        header(t.header, 0, 100, 5, "odom" if child == "base_link" else "base_link")
        t.child_frame_id = child
        t.transform.translation.x = x
        t.transform.rotation.w = 1.0
        tf.transforms.append(t)
    write(out_dir, "tf", tf)

    image = Image()
    header(image.header, 1, 10, 0, "camera")
    image.height = 2
    image.width = 3
    image.encoding = "rgb8"
    image.step = 9
    image.data = bytes(range(18))
    write(out_dir, "image_rgb8", image)
    image.encoding = "yuv422"
    write(out_dir, "image_yuv422", image)

    compressed = CompressedImage()
    header(compressed.header, 2, 11, 0, "camera")
    compressed.format = "png"
    compressed.data = b"\x89PNG not really"
    write(out_dir, "compressed", compressed)

    info = CameraInfo()
    header(info.header, 4, 12, 0, "camera")
    info.height = 960
    info.width = 1280
    info.distortion_model = "plumb_bob"
    info.D = [0.1, -0.2, 0.001, 0.002, 0.0]
    info.K = [1000.0, 0.0, 640.0, 0.0, 1001.0, 480.0, 0.0, 0.0, 1.0]
    info.R = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    info.P = [1000.0, 0, 640.0, 0, 0, 1001.0, 480.0, 0, 0, 0, 1.0, 0]
    write(out_dir, "camerainfo", info)


if __name__ == "__main__":
    main(sys.argv[1])
