"""Planar poses for the bench/laser scripts: (x, y, theta) composition and TUM trajectories."""
import math


def compose(p, q):
    c, s = math.cos(p[2]), math.sin(p[2])
    return (p[0] + c * q[0] - s * q[1], p[1] + s * q[0] + c * q[1], p[2] + q[2])


def inverse(p):
    c, s = math.cos(p[2]), math.sin(p[2])
    return (-c * p[0] - s * p[1], s * p[0] - c * p[1], -p[2])


def between(p, q):
    """q in the frame of p."""
    return compose(inverse(p), q)


def read_tum(path):
    """{stamp: (x, y, theta)} of a TUM trajectory (t x y z qx qy qz qw; yaw only). The first pose
    of a repeated stamp is kept (Intel has 135), as `waymark eval relations` keeps it."""
    poses = {}
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        f = [float(v) for v in line.split()]
        poses.setdefault(f[0], (f[1], f[2], 2 * math.atan2(f[6], f[7])))
    return poses
