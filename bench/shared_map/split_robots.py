#!/usr/bin/env python3
"""Issue 38 (docs/results.md, "One map for two robots"): a CARMEN log split into --robots slices
(two by default) of equal length, each overlapping the next by a fraction of a slice, replayed one
after the other as robots r1, r2, ... into one map on a fresh waymark-server, every robot but r1
without a start pose. Each robot is replayed once the one before it was tied in (and, with the
server's follow on, followed to its last node). Prints one JSON line: whether every robot was tied
in, at which of its scans and how many seconds after its first (from the server's log), each robot
against the one before over their overlap, the relations error (`waymark eval relations`) of the
merged map-frame trajectory (r1's poses, then r2's after r1's last scan, then r3's after r2's
last, ...), of each robot alone and of the single session, and the acceptance index of the merged
grid against the single session's (acceptance_index.py).

  split_robots.py LOG RELATIONS --overlap 0.25 --single-dir OUT/single --out OUT/aces-25 \\
      [--build build] [--port 50961] [--robots 2] [--server-arg=--slam-map-follow=false ...]

--single-dir holds the single session's replay of the whole log (`waymark slam replay LOG --out
DIR`: trajectory.txt and map.pgm), made once per log. --server-arg passes one more flag to
waymark-server (repeatable; write it with '=' so that it is not read as this script's own), e.g.
--server-arg=--slam-map-follow=false for the single origin found at the tie.

Slices: with N robots and overlap f over S scans, each slice is round(S / (N - (N - 1) f)) scans
long, the first starts at scan 0, the last ends at the log's last, the ones between are spread
evenly (int(k (S - length) / (N - 1)) for robot k + 1).

JSON, for robot k >= 2 (rk): rk_tie (from the server's "tied in at" line: tie x, y, theta,
tied_at_scan, tied_after_s, searches, unique, ambiguous, disagreeing, mreads), rk_follow when the
server logged "followed to its last node" for it (windowed matches, origin samples, weak,
ambiguous, beyond, mreads; absent with the follow off), and rk_vs_r(k-1)_m. With two robots the fields of
r2's tie are also at the top level, as before (tie, tied_at_scan, ...)."""
import argparse, json, math, os, re, subprocess, sys, time

p = argparse.ArgumentParser()
p.add_argument('log'); p.add_argument('relations')
p.add_argument('--overlap', type=float, required=True)
p.add_argument('--single-dir', required=True)
p.add_argument('--out', required=True)
p.add_argument('--build', default='build')
p.add_argument('--port', default='50961')
p.add_argument('--robots', type=int, default=2)
p.add_argument('--server-arg', action='append', default=[],
               help='one more waymark-server flag (repeatable): --server-arg=--slam-map-follow=false')
p.add_argument('--follow-timeout', type=float, default=600,
               help='seconds to wait for the server to have followed a robot to its last node')
a = p.parse_args()
if a.robots < 2:
    sys.exit('--robots: at least 2')
W = os.path.join(a.build, 'bin', 'waymark')
SERVER = os.path.join(a.build, 'bin', 'waymark-server')
here = os.path.dirname(os.path.abspath(__file__))
os.makedirs(a.out, exist_ok=True)
env = dict(os.environ, WAYMARK_SERVER='127.0.0.1:' + a.port)
# The follow is on unless a --server-arg turns it off: then no "followed" line is waited for.
follow_on = not any(re.fullmatch(r'--slam-map-follow[= ](false|0|no|off)', s.strip(), re.I)
                    for s in a.server_arg)


def w(*args):
    r = subprocess.run([W, *args], env=env, capture_output=True, text=True)
    if r.returncode not in (0, 3):  # 3: the map's self-check warned; everything is written
        sys.exit(f'waymark {" ".join(args)}: exit {r.returncode}: {r.stderr}')
    return r


def relations(trajectory):
    r = subprocess.run([W, 'eval', 'relations', trajectory, a.relations, '--json'],
                       capture_output=True, text=True)
    ev = json.loads(r.stdout)
    return {'used': ev['relations_used'], 'trans_m': round(ev['trans_abs_mean'], 4),
            'trans_std_m': round(ev['trans_abs_std'], 4), 'rot_deg': round(ev['rot_abs_mean_deg'], 3)}


def tum(path):
    return {line.split()[0]: line for line in open(path) if line.strip() and not line.startswith('#')}


def write_tum(path, poses):
    with open(path, 'w') as f:
        f.write('# t x y z qx qy qz qw\n')
        for k in sorted(poses, key=float):
            f.write(poses[k])


def server_log():
    return open(a.out + '/server.log').read()


def tie_line(session):
    found = re.search(re.escape(session) + r' tied in at \(([-\d.]+), ([-\d.]+), ([-\d.]+)\) at its '
                      r'scan (\d+) \(([\d.]+) s after.*; (\d+) searches, (\d+) unique matches, (\d+) '
                      r'ambiguous, (\d+) disagreeing pairs, (\d+) M', server_log())
    if not found:
        return None
    g = lambda i: int(found.group(i))
    return {'tie': [float(found.group(i)) for i in (1, 2, 3)], 'tied_at_scan': g(4),
            'tied_after_s': float(found.group(5)), 'searches': g(6), 'unique': g(7),
            'ambiguous': g(8), 'disagreeing': g(9), 'mreads': g(10)}


def follow_line(session):
    found = re.search(re.escape(session) + r' \(closed\) followed to its last node: (\d+) windowed '
                      r'matches, (\d+) origin samples, (\d+) weak, (\d+) ambiguous'
                      r'(?:, (\d+) beyond their uncertainty)?(?:, (\d+) M)?',
                      server_log())
    if not found:
        return None
    return {'windowed': int(found.group(1)), 'samples': int(found.group(2)),
            'weak': int(found.group(3)), 'ambiguous': int(found.group(4)),
            'beyond': int(found.group(5)) if found.group(5) else 0,
            'mreads': int(found.group(6)) if found.group(6) else None}


# The log as the server reads it: plain, bzip2 or gzip.
reader = 'bzcat' if a.log.endswith('.bz2') else 'zcat' if a.log.endswith('.gz') else 'cat'
scans = sum(1 for line in subprocess.run([reader, a.log], capture_output=True,
                                         text=True).stdout.splitlines()
            if line.startswith(('FLASER', 'ROBOTLASER1')))
n = a.robots
length = int(round(scans / (n - (n - 1) * a.overlap)))
slices = [(int(k * (scans - length) / (n - 1)), int(k * (scans - length) / (n - 1)) + length)
          for k in range(n)]
names = [f'r{k + 1}' for k in range(n)]
server = subprocess.Popen([SERVER, '--listen', '127.0.0.1:' + a.port, '--db', a.out + '/w.db',
                           '--insecure-dev', *a.server_arg], stdout=open(a.out + '/server.log', 'w'),
                          stderr=subprocess.STDOUT)
try:
    time.sleep(1.5)
    w('map', 'create', 'm')
    res = {'log': os.path.basename(a.log), 'overlap': a.overlap, 'robots': n,
           'server_args': a.server_arg, 'follow': follow_on}
    res.update({name: list(s) for name, s in zip(names, slices)})
    tied = True
    m = None
    for k, (name, s) in enumerate(zip(names, slices)):
        w('slam', 'replay', a.log, '--map', 'm', '--scans', f'{s[0]}:{s[1]}', '--robot', name,
          '--out', f'{a.out}/{name}')
        if k == 0:
            continue
        robot_tied = False
        for _ in range(600):  # the tie may be stored after the replay: its searches catch up
            m = json.loads(w('--json', 'map', 'show', 'm').stdout)
            if m['trajectories'][k].get('tied_in'):
                robot_tied = True
                break
            # The server searched the closed session to its last scan: no tie is coming.
            if (m['trajectories'][k]['session_id'] + ' (closed) was searched for to its last scan'
                    in server_log()):
                break
            time.sleep(0.5)
        session = m['trajectories'][k]['session_id']
        if robot_tied:
            for _ in range(20):  # the log line follows the stored tie
                if tie_line(session):
                    break
                time.sleep(0.25)
        res[f'{name}_tie'] = tie_line(session)
        if robot_tied and follow_on:
            deadline = time.time() + a.follow_timeout
            while not follow_line(session) and time.time() < deadline:
                time.sleep(0.5)
        res[f'{name}_follow'] = follow_line(session)
        if not robot_tied:
            tied = False
            break
    res['tied'] = tied
    if n == 2 and res.get('r2_tie'):
        res.update(res['r2_tie'])
    if tied:
        m = json.loads(w('--json', 'map', 'show', 'm').stdout)
        ids = [t['session_id'] for t in m['trajectories']]
        res['origin_samples'] = {name: len(t.get('origin_samples', []))
                                 for name, t in zip(names, m['trajectories'])}
        poses = []
        for name, session in zip(names, ids):
            w('slam', 'trajectory', session, '--frame', 'map', '--out', f'{a.out}/{name}_map.txt')
            poses.append(tum(f'{a.out}/{name}_map.txt'))
        grid = json.loads(w('--json', 'map', 'grid', 'm', '--out', a.out + '/grid').stdout)
        # The map's segment map: how many walls several robots mapped were fused into one.
        res['segments'] = {'map': grid['segments'], 'fused': grid['fused_segments']}
        merged = {}
        for p_k in reversed(poses):
            merged.update(p_k)  # an earlier robot's poses where both have one
        write_tum(a.out + '/merged.txt', merged)
        res['relations'] = {'merged': relations(a.out + '/merged.txt')}
        for name, p_k in zip(names, poses):
            write_tum(f'{a.out}/{name}_only.txt', p_k)
            res['relations'][f'{name}_alone'] = relations(f'{a.out}/{name}_only.txt')
        res['relations']['single'] = relations(a.single_dir + '/trajectory.txt')
        xy = lambda line: (float(line.split()[1]), float(line.split()[2]))
        for k in range(1, n):
            before, this = poses[k - 1], poses[k]
            overlap = sorted((t for t in this if t in before), key=float)
            d = [math.dist(xy(before[t]), xy(this[t])) for t in overlap]
            res[f'{names[k]}_vs_{names[k - 1]}_m'] = (
                {'at_start': round(d[0], 3), 'mean': round(sum(d) / len(d), 3),
                 'max': round(max(d), 3)} if d else None)
        index = subprocess.run([sys.executable, os.path.join(here, 'acceptance_index.py'),
                                a.out + '/grid/map.pgm', a.single_dir + '/map.pgm'],
                               capture_output=True, text=True).stdout.split()
        res['acceptance_index'] = float(index[0]) if index else None
    print(json.dumps(res))
finally:
    server.terminate()
    server.wait()
