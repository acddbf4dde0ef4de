#!/usr/bin/python3
"""A ROS 1 bag (Debian's rosbag) with two sensor_msgs/LaserScan topics, /scan_front and
/scan_rear, 30 scans each at 10 Hz of a robot driving along a corridor, and /odom: the bag
`slam replay` must not choose from on its own (tests/ros/bag_replay_test.cc).

  write_two_laser_bag.py OUT.bag"""
import math
import sys

import genpy
import rosbag
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan


def main(path):
    bag = rosbag.Bag(path, "w")
    try:
        for i in range(30):
            stamp = genpy.Time(1000 + i // 10, (i % 10) * 100000000)
            x = 0.05 * i
            odom = Odometry()
            odom.header.stamp = stamp
            odom.header.frame_id = "odom"
            odom.child_frame_id = "base_link"
            odom.pose.pose.position.x = x
            odom.pose.pose.orientation.w = 1.0
            bag.write("/odom", odom, stamp)
            for topic, frame, heading in (("/scan_front", "base_link", 0.0),
                                          ("/scan_rear", "base_link", math.pi)):
                scan = LaserScan()
                scan.header.stamp = stamp
                scan.header.frame_id = frame
                scan.angle_min = -math.pi / 2
                scan.angle_increment = math.pi / 180
                scan.angle_max = scan.angle_min + 180 * scan.angle_increment
                scan.range_min = 0.05
                scan.range_max = 8.0
                # Walls 1 m to each side of a corridor along x.
                ranges = []
                for b in range(181):
                    bearing = scan.angle_min + b * scan.angle_increment + heading
                    s = abs(math.sin(bearing))
                    ranges.append(min(1.0 / s, 8.5) if s > 1e-6 else 8.5)
                scan.ranges = ranges
                bag.write(topic, scan, stamp)
    finally:
        bag.close()


if __name__ == "__main__":
    main(sys.argv[1])
