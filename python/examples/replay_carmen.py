#!/usr/bin/env python3
"""Replays the first scans of a CARMEN log into a laser SLAM session and prints the final pose.

    PYTHONPATH=python:build/python python3 python/examples/replay_carmen.py \
        --server 127.0.0.1:50051 --scans 200 ../shared/data/laser/intel/intel.clf.bz2

Each FLASER line becomes the robot's odometry (the line's odometry pose) and a scan of its beams
over 180 degrees, in stamp order, as `waymark slam replay` sends them
(client/sessions/slam_replay.cc).
Reads plain, .gz and .bz2 logs. A server with authentication needs --token (or WAYMARK_TOKEN).
"""
import argparse
import bz2
import gzip
import heapq
import math
import os
import sys

import waymark


def open_log(path):
    if path.endswith(".bz2"):
        return bz2.open(path, "rt", errors="replace")
    if path.endswith(".gz"):
        return gzip.open(path, "rt", errors="replace")
    return open(path, "rt", errors="replace")


def flaser_lines(path):
    """(stamp, ranges, odometry (x, y, theta), laser pose (x, y, theta)) of each FLASER line:
    FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp."""
    with open_log(path) as log:
        for number, line in enumerate(log, 1):
            fields = line.split()
            if not fields or fields[0] != "FLASER":
                continue
            try:
                n = int(fields[1])
                if n <= 0 or len(fields) != n + 11:
                    raise ValueError(f"{len(fields)} fields for {n} beams")
                ranges = [float(r) for r in fields[2:2 + n]]
                laser = tuple(float(v) for v in fields[2 + n:5 + n])
                odom = tuple(float(v) for v in fields[5 + n:8 + n])
                stamp = float(fields[8 + n])
            except ValueError as e:
                sys.exit(f"{path}:{number}: malformed FLASER line: {e}")
            yield stamp, ranges, odom, laser


def in_stamp_order(lines, lookahead=64):
    """The lines with strictly increasing stamps, as a session takes them: reordered within
    `lookahead` lines (the Intel log has FLASER lines up to 14 lines out of place), a line whose
    stamp still does not increase is skipped (client/datasets/carmen_laser_feed.h)."""
    pending, last, order = [], None, 0
    for line in lines:
        heapq.heappush(pending, (line[0], order, line))
        order += 1
        if len(pending) > lookahead:
            stamp, _, line = heapq.heappop(pending)
            if last is None or stamp > last:
                last = stamp
                yield line
    while pending:
        stamp, _, line = heapq.heappop(pending)
        if last is None or stamp > last:
            last = stamp
            yield line


def beam_step(n):
    """FLASER lines cover 180 degrees (client/datasets/carmen_log.cc): 180 or 181 beams every
    degree, 360 or 361 every half degree."""
    if n in (180, 181):
        return math.pi / 180
    if n in (360, 361):
        return math.pi / 360
    return math.pi / n


def laser_mount(odom, laser):
    """The laser's pose on the robot from one line (odometry^-1 * laser pose), when plausible."""
    dx, dy = laser[0] - odom[0], laser[1] - odom[1]
    c, s = math.cos(-odom[2]), math.sin(-odom[2])
    x, y = c * dx - s * dy, s * dx + c * dy
    theta = math.atan2(math.sin(laser[2] - odom[2]), math.cos(laser[2] - odom[2]))
    return (x, y, theta) if math.hypot(x, y) < 1.0 and abs(theta) < 0.1 else (0.0, 0.0, 0.0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("log", help="CARMEN log (.clf, .log, .gz, .bz2)")
    parser.add_argument("--server", default=os.environ.get("WAYMARK_SERVER", "127.0.0.1:50051"))
    parser.add_argument("--token", default=os.environ.get("WAYMARK_TOKEN"))
    parser.add_argument("--tls-ca", default=os.environ.get("WAYMARK_TLS_CA"))
    parser.add_argument("--scans", type=int, default=200, help="scans to send (0 = all)")
    parser.add_argument("--robot-id", default="python-replay")
    parser.add_argument("--keep", action="store_true", help="keep the session (default: delete)")
    args = parser.parse_args()

    lines = in_stamp_order(flaser_lines(args.log))
    first = next(lines, None)
    if first is None:
        sys.exit(f"{args.log}: no FLASER line")
    n = len(first[1])
    client = waymark.connect(args.server, token=args.token, ca_file=args.tls_ca)

    def readings():
        sent = 0
        for stamp, ranges, odom, _ in _chain(first, lines):
            if args.scans and sent >= args.scans:
                return
            yield waymark.Odometry(stamp, *odom)
            yield waymark.Scan(stamp, ranges)
            sent += 1

    try:
        session = client.create_laser_session(
            args.robot_id, f"replay of {os.path.basename(args.log)}", beam_count=n,
            angle_min=-math.pi / 2, angle_increment=beam_step(n),
            laser_pose=laser_mount(first[2], first[3]))
        last, processed, rejected = None, 0, 0
        for update in client.stream_laser(session.session_id, readings()):
            if update.rejection:
                rejected += 1
                print(f"rejected message {update.sequence}: {update.rejection.code.name}: "
                      f"{update.rejection.message}", file=sys.stderr)
            else:
                processed += 1
                last = update
        closed = client.close_session(session.session_id)
        if last is None:
            sys.exit("no scan was processed")
        # The trajectory after closing is in the final map frame (loop closures applied); the
        # last answer's pose was the estimate when that scan was processed.
        poses = client.get_trajectory(session.session_id).poses
        pose = poses[-1].pose if poses else last.pose
        print(f"session {session.session_id}: {processed} scans answered, {rejected} rejected, "
              f"{closed.scans_processed} processed, {closed.segments} segments")
        print(f"final pose x={pose.x:.3f} m y={pose.y:.3f} m theta={pose.theta:.3f} rad")
        if not args.keep:
            client.delete_session(session.session_id)
    except waymark.Error as e:
        sys.exit(f"error: {e}")


def _chain(first, rest):
    yield first
    yield from rest


if __name__ == "__main__":
    main()
