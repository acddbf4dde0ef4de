#!/usr/bin/env python3
"""Checks a replay's loop closures against a log's relations (issue 33; docs/results.md).

  closures_vs_relations.py TRAJECTORY.txt RELATIONS CLOSURES [--within 15] [--all]

TRAJECTORY: the replay's poses (TUM, `waymark-laser-eval --out DIR`: DIR/trajectory.txt);
CLOSURES: its loop constraints (`waymark-laser-eval --save-closures FILE`). A closure from node a
to node b is checked where the relations hold one from t1 near a to t2 near b (both within
--within seconds; the nearest such pair): the truth of a -> b is then a -> t1 and t2 -> b from the
trajectory (its local error, a few cm over seconds) around the relation t1 -> t2. Prints the
closures more than 0.3 m off (all with --all), and how many were checked and how many are more
than 0.5 m off. What it cannot see: closures with no relation near both ends."""
import argparse, bisect, math

from tum_se2 import between, compose, read_tum

p = argparse.ArgumentParser()
p.add_argument('trajectory'); p.add_argument('relations'); p.add_argument('closures')
p.add_argument('--within', type=float, default=15.0)
p.add_argument('--all', action='store_true')
a = p.parse_args()

poses = read_tum(a.trajectory)
stamps = sorted(poses)


def pose_at(t):
    i = bisect.bisect_left(stamps, t - 0.005)
    for j in (i - 1, i, i + 1):
        if 0 <= j < len(stamps) and abs(stamps[j] - t) < 0.01:
            return poses[stamps[j]]
    return None


relations = []
for line in open(a.relations):
    f = line.split()
    if len(f) < 8 or f[0].startswith('#'):
        continue
    relations.append((float(f[0]), float(f[1]), (float(f[2]), float(f[3]), float(f[7]))))
relations.sort()
firsts = [r[0] for r in relations]

checked = wrong = total = 0
for line in open(a.closures):
    if line.startswith('#') or not line.strip():
        continue
    f = line.split()
    total += 1
    ta, tb = float(f[0]), float(f[1])
    closure = (float(f[2]), float(f[3]), float(f[4]))
    enabled, score = f[8] == '1', float(f[9])
    pa, pb = pose_at(ta), pose_at(tb)
    if pa is None or pb is None:
        continue
    best = None
    for t1, t2, r in relations[bisect.bisect_left(firsts, ta - a.within):
                               bisect.bisect_right(firsts, ta + a.within)]:
        if abs(t2 - tb) <= a.within:
            cost = abs(t1 - ta) + abs(t2 - tb)
            if best is None or cost < best[0]:
                best = (cost, t1, t2, r)
    if best is None:
        continue
    _, t1, t2, r = best
    p1, p2 = pose_at(t1), pose_at(t2)
    if p1 is None or p2 is None:
        continue
    truth = compose(compose(between(pa, p1), r), between(p2, pb))
    error = math.hypot(truth[0] - closure[0], truth[1] - closure[1])
    heading = abs(math.remainder(truth[2] - closure[2], 2 * math.pi))
    graph = between(pa, pb)
    graph_error = math.hypot(truth[0] - graph[0], truth[1] - graph[1])
    checked += 1
    wrong += error > 0.5
    if error > 0.3 or a.all:
        print(f'{ta - stamps[0]:9.1f} s -> {tb - stamps[0]:9.1f} s  enabled {int(enabled)}  score '
              f'{score:.3f}  off {error:.2f} m {math.degrees(heading):.1f} deg  final graph off '
              f'{graph_error:.2f} m{"  WRONG" if error > 0.5 else ""}')
print(f'closures {total}, checked {checked}, more than 0.5 m off {wrong}')
