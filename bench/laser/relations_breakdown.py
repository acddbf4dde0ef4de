#!/usr/bin/env python3
"""Where a trajectory's relations error comes from (issue 33; docs/results.md).

  relations_breakdown.py TRAJECTORY.txt RELATIONS [--bin 500] [--worst 10]

TRAJECTORY: a replay's poses (TUM, `waymark-laser-eval --out DIR`: DIR/trajectory.txt);
RELATIONS: Kummerle-style relations (t1 t2 x y z roll pitch yaw), as `waymark eval relations`
reads them. Prints the mean translation error over all relations and the local ones (t2 - t1 <=
10 s), the mean per bin of --bin seconds of t1, the share of the total that relations over 0.3 m
make, the --worst relations, and the mean over the relations whose two ends are not turning (the
trajectory's own heading rate at each end below 0.35, 0.17, 0.09 and 0.05 rad/s).

The last line says how much a reference whose stamps are uncertain moves the score: a relation
that names the scan next to the one it was measured at is off by the robot's turn between them, at
a turning end, times the lever arm to the other end (MIT Killian's restamped relations name their
scan or its neighbour, 0.44 s apart: docs/results.md)."""
import argparse, bisect, math

from tum_se2 import between, read_tum

p = argparse.ArgumentParser()
p.add_argument('trajectory')
p.add_argument('relations')
p.add_argument('--bin', type=float, default=500.0)
p.add_argument('--worst', type=int, default=10)
a = p.parse_args()


poses = read_tum(a.trajectory)
stamps = sorted(poses)


def index_at(t):
    # The nearest pose within 1 ms, as `waymark eval relations` looks it up.
    i = bisect.bisect_left(stamps, t)
    near = [j for j in (i - 1, i) if 0 <= j < len(stamps) and abs(stamps[j] - t) <= 1e-3]
    return min(near, key=lambda j: abs(stamps[j] - t)) if near else None


def turn_rate(j):
    lo, hi = max(0, j - 1), min(len(stamps) - 1, j + 1)
    if hi == lo or stamps[hi] == stamps[lo]:
        return 0.0
    turn = math.remainder(poses[stamps[hi]][2] - poses[stamps[lo]][2], 2 * math.pi)
    return abs(turn) / (stamps[hi] - stamps[lo])


rows = []  # (t1, t2, translation error m, rotation error rad, turn rate at the faster end)
for line in open(a.relations):
    f = line.split()
    if len(f) < 8 or f[0].startswith('#'):
        continue
    t1, t2 = float(f[0]), float(f[1])
    i, j = index_at(t1), index_at(t2)
    if i is None or j is None:
        continue
    measured = (float(f[2]), float(f[3]), float(f[7]))
    estimated = between(poses[stamps[i]], poses[stamps[j]])
    e = between(measured, estimated)
    rows.append((t1, t2, math.hypot(e[0], e[1]), abs(math.remainder(e[2], 2 * math.pi)),
                 max(turn_rate(i), turn_rate(j))))
if not rows:
    raise SystemExit('no relation names two stamps of the trajectory')


def mean(values):
    values = list(values)
    return sum(values) / len(values) if values else float('nan')


local = [r for r in rows if r[1] - r[0] <= 10.0]
print('relations %d of the file scored: all %.4f m, local (<= 10 s) %.4f m over %d' %
      (len(rows), mean(r[2] for r in rows), mean(r[2] for r in local), len(local)))
bins = {}
first = min(r[0] for r in rows)
for r in rows:
    bins.setdefault(int((r[0] - first) // a.bin), []).append(r[2])
for k in sorted(bins):
    print('  t1 +%7.0f s: %4d relations, mean %.3f m, max %.3f m' %
          (k * a.bin, len(bins[k]), mean(bins[k]), max(bins[k])))
total = sum(r[2] for r in rows)
large = [r for r in rows if r[2] > 0.3]
print('relations over 0.3 m: %d, %.0f %% of the total error' %
      (len(large), 100.0 * sum(r[2] for r in large) / total))
for r in sorted(rows, key=lambda r: -r[2])[:a.worst]:
    print('  %.1f -> %.1f (%.1f s): %.3f m, %.2f deg, ends turning up to %.2f rad/s' %
          (r[0], r[1], r[1] - r[0], r[2], math.degrees(r[3]), r[4]))
for limit in (0.35, 0.17, 0.09, 0.05):
    kept = [r for r in rows if r[4] < limit]
    print('ends turning under %.2f rad/s: %d relations, all %.4f m, local %.4f m' %
          (limit, len(kept), mean(r[2] for r in kept),
           mean(r[2] for r in kept if r[1] - r[0] <= 10.0)))
