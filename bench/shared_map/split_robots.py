#!/usr/bin/env python3
"""Issue 38 (docs/results.md, "One map for two robots"): a CARMEN log split into two slices of
equal length overlapping by a fraction of a slice, replayed one after the other as robots r1 and
r2 into one map on a fresh waymark-server, r2 without a start pose. Prints one JSON line: whether
r2 was tied in, at which of its scans and how many seconds after its first (from the server's
log), r2 against r1 over the overlap, the relations error (`waymark eval relations`) of the
merged map-frame trajectory (r1's poses, then r2's after r1's last scan), of each robot alone and
of the single session, and the acceptance index of the merged grid against the single session's
(acceptance_index.py).

  split_robots.py LOG RELATIONS --overlap 0.25 --single-dir OUT/single --out OUT/aces-25 \\
      [--build build] [--port 50961]

--single-dir holds the single session's replay of the whole log (`waymark slam replay LOG --out
DIR`: trajectory.txt and map.pgm), made once per log."""
import argparse, json, math, os, re, subprocess, sys, time

p = argparse.ArgumentParser()
p.add_argument('log'); p.add_argument('relations')
p.add_argument('--overlap', type=float, required=True)
p.add_argument('--single-dir', required=True)
p.add_argument('--out', required=True)
p.add_argument('--build', default='build')
p.add_argument('--port', default='50961')
a = p.parse_args()
W = os.path.join(a.build, 'bin', 'waymark')
SERVER = os.path.join(a.build, 'bin', 'waymark-server')
here = os.path.dirname(os.path.abspath(__file__))
os.makedirs(a.out, exist_ok=True)
env = dict(os.environ, WAYMARK_SERVER='127.0.0.1:' + a.port)


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


scans = sum(1 for line in subprocess.run(['bzcat' if a.log.endswith('.bz2') else 'cat', a.log],
                                         capture_output=True, text=True).stdout.splitlines()
            if line.startswith(('FLASER', 'ROBOTLASER1')))
length = int(round(scans / (2 - a.overlap)))
r1, r2 = (0, length), (scans - length, scans)
server = subprocess.Popen([SERVER, '--listen', '127.0.0.1:' + a.port, '--db', a.out + '/w.db',
                           '--insecure-dev'], stdout=open(a.out + '/server.log', 'w'),
                          stderr=subprocess.STDOUT)
try:
    time.sleep(1.5)
    w('map', 'create', 'm')
    w('slam', 'replay', a.log, '--map', 'm', '--scans', f'{r1[0]}:{r1[1]}', '--robot', 'r1', '--out', a.out + '/r1')
    w('slam', 'replay', a.log, '--map', 'm', '--scans', f'{r2[0]}:{r2[1]}', '--robot', 'r2', '--out', a.out + '/r2')
    tied = False
    for _ in range(600):  # the tie may be stored after the replay: its searches catch up
        m = json.loads(w('--json', 'map', 'show', 'm').stdout)
        if m['trajectories'][1].get('tied_in'):
            tied = True
            break
        time.sleep(0.5)
    res = {'log': os.path.basename(a.log), 'overlap': a.overlap, 'r1': r1, 'r2': r2, 'tied': tied}
    found = re.search(r'tied in at \(([-\d.]+), ([-\d.]+), ([-\d.]+)\) at its scan (\d+) \(([\d.]+) s '
                      r'after.*; (\d+) searches, (\d+) unique matches, (\d+) ambiguous, (\d+) '
                      r'disagreeing pairs, (\d+) M', open(a.out + '/server.log').read())
    if found:
        res.update(tie=[float(found.group(i)) for i in (1, 2, 3)], tied_at_scan=int(found.group(4)),
                   tied_after_s=float(found.group(5)), searches=int(found.group(6)),
                   unique=int(found.group(7)), ambiguous=int(found.group(8)),
                   disagreeing=int(found.group(9)), mreads=int(found.group(10)))
    if tied:
        ids = [t['session_id'] for t in m['trajectories']]
        w('slam', 'trajectory', ids[0], '--frame', 'map', '--out', a.out + '/r1_map.txt')
        w('slam', 'trajectory', ids[1], '--frame', 'map', '--out', a.out + '/r2_map.txt')
        w('map', 'grid', 'm', '--out', a.out + '/grid')
        p1, p2 = tum(a.out + '/r1_map.txt'), tum(a.out + '/r2_map.txt')
        merged = dict(p2)
        merged.update(p1)  # r1's poses where both have one
        write_tum(a.out + '/merged.txt', merged)
        write_tum(a.out + '/r1_only.txt', p1)
        write_tum(a.out + '/r2_only.txt', p2)
        res['relations'] = {'merged': relations(a.out + '/merged.txt'),
                            'r1_alone': relations(a.out + '/r1_only.txt'),
                            'r2_alone': relations(a.out + '/r2_only.txt'),
                            'single': relations(a.single_dir + '/trajectory.txt')}
        xy = lambda line: (float(line.split()[1]), float(line.split()[2]))
        overlap = sorted((k for k in p2 if k in p1), key=float)
        d = [math.dist(xy(p1[k]), xy(p2[k])) for k in overlap]
        res['r2_vs_r1_m'] = {'at_r2_start': round(d[0], 3), 'mean': round(sum(d) / len(d), 3),
                             'max': round(max(d), 3)}
        index = subprocess.run([sys.executable, os.path.join(here, 'acceptance_index.py'),
                                a.out + '/grid/map.pgm', a.single_dir + '/map.pgm'],
                               capture_output=True, text=True).stdout.split()
        res['acceptance_index'] = float(index[0]) if index else None
    print(json.dumps(res))
finally:
    server.terminate()
    server.wait()
