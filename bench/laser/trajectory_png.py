#!/usr/bin/env python3
"""A trajectory drawn as a PNG, coloured by time (blue at the start, red at the end), with a black
square every N poses: to see where a map bends, put the odometry, the front end alone
(`waymark-laser-eval --mapping-opt min_loop_travel=1e9 --out DIR`) and the full run side by side.
No third-party modules.

  bench/laser/trajectory_png.py TRAJECTORY.txt OUT.png [--every N] [--size PIXELS]

TRAJECTORY.txt is TUM (`t x y z qx qy qz qw`, as `waymark-laser-eval --out` and `waymark slam
trajectory` write it); OUT.png is PIXELS (default 1100) on its longer side plus a 20 px margin.
"""
import argparse
import struct
import zlib


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trajectory")
    parser.add_argument("out")
    parser.add_argument("--every", type=int, default=500, help="a marker every N poses")
    parser.add_argument("--size", type=int, default=1100, help="pixels on the longer side")
    args = parser.parse_args()
    points = []
    for line in open(args.trajectory):
        if line.startswith("#") or not line.strip():
            continue
        fields = line.split()
        points.append((float(fields[1]), float(fields[2])))
    if len(points) < 2:
        raise SystemExit("trajectory_png: fewer than two poses in " + args.trajectory)
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    min_x, max_x, min_y, max_y = min(xs), max(xs), min(ys), max(ys)
    scale = args.size / max(max_x - min_x, max_y - min_y, 1e-9)
    width = int((max_x - min_x) * scale) + 41
    height = int((max_y - min_y) * scale) + 41
    image = [[(255, 255, 255)] * width for _ in range(height)]

    def put(x, y, colour, radius):
        for dx in range(-radius, radius + 1):
            for dy in range(-radius, radius + 1):
                px, py = int(x) + dx, int(y) + dy
                if 0 <= px < width and 0 <= py < height:
                    image[py][px] = colour

    def pixel(p):
        return 20 + (p[0] - min_x) * scale, 20 + (max_y - p[1]) * scale

    n = len(points)
    for i in range(1, n):
        a, b = pixel(points[i - 1]), pixel(points[i])
        f = i / n
        colour = (int(255 * f), int(120 * (1 - abs(2 * f - 1))), int(255 * (1 - f)))
        steps = int(max(abs(b[0] - a[0]), abs(b[1] - a[1]))) + 1
        for k in range(steps + 1):
            t = k / steps
            put(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), colour, 1)
    for i in range(0, n, args.every):
        put(*pixel(points[i]), (0, 0, 0), 4)
    raw = b"".join(b"\x00" + bytes(v for px in row for v in px) for row in image)

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    with open(args.out, "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n")
        out.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)))
        out.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        out.write(chunk(b"IEND", b""))
    print(f"{args.out}: {n} poses, {max_x - min_x:.1f} x {max_y - min_y:.1f} m")


if __name__ == "__main__":
    main()
