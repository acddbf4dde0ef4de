#!/usr/bin/env python3
"""Issue 38: one pair of simulated robots, recorded once, followed with one server setting
(docs/results.md, "Tried, not kept: a jump only where staying is contradicted"). A second live
`sim explore` run cannot compare two settings: the server's answers steer the robots, so their
paths part. Here both robots' recorded logs (`waymark sim explore --robots 2 --map M --record
REC --out RUN`, known starts) are replayed at once into a new map on a fresh waymark-server with
the given flags, robot 2 at its true start in robot 1's frame, and robot 2's map-frame trajectory
is scored against its true one.

  sim_replay_ab.py REC RUN OUT [--build build] [--port 51230] [--speed 40] [-- SERVER FLAGS...]

--speed: both replays at the simulation's pace times this (0: as fast as the server answers; the
follow then catches up after the replays, against robot 1's whole map, which is not what a live
run meets). Prints one JSON line: robot 2's poses matched to the truth, their mean and largest
position error (m), and the server's "followed to its last node" counts for robot 2."""
import argparse, json, math, os, re, subprocess, sys, time

argv = sys.argv[1:]
server_flags = []
if '--' in argv:
    server_flags = argv[argv.index('--') + 1:]
    argv = argv[:argv.index('--')]
p = argparse.ArgumentParser()
p.add_argument('rec'); p.add_argument('run'); p.add_argument('out')
p.add_argument('--build', default='build')
p.add_argument('--port', default='51230')
p.add_argument('--speed', type=float, default=40.0)
a = p.parse_args(argv)
W = os.path.join(a.build, 'bin', 'waymark')
SERVER = os.path.join(a.build, 'bin', 'waymark-server')
os.makedirs(a.out, exist_ok=True)
env = dict(os.environ, WAYMARK_SERVER='127.0.0.1:' + a.port)
speed = ['--speed', str(a.speed)] if a.speed > 0 else []


def w(*args):
    return subprocess.run([W, *args], env=env, capture_output=True, text=True)


def tum(path):
    poses = {}
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        f = line.split()
        poses[round(float(f[0]), 3)] = (float(f[1]), float(f[2]),
                                        2 * math.atan2(float(f[6]), float(f[7])))
    return poses


def relative(a, b):  # pose b in the frame of pose a
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    return (c * dx + s * dy, -s * dx + c * dy, b[2] - a[2])


server = subprocess.Popen([SERVER, '--listen', '127.0.0.1:' + a.port, '--db', a.out + '/w.db',
                           '--insecure-dev', *server_flags],
                          stdout=open(a.out + '/server.log', 'w'), stderr=subprocess.STDOUT)
try:
    for _ in range(100):
        if w('map', 'create', 'm').returncode == 0:
            break
        time.sleep(0.2)
    true1 = tum(a.run + '/robot1/trajectory_true.txt')
    true2 = tum(a.run + '/robot2/trajectory_true.txt')
    start1, start2 = true1[min(true1)], true2[min(true2)]
    at = relative(start1, start2)
    replay = lambda robot, extra: subprocess.Popen(
        [W, 'slam', 'replay', f'{a.rec}/robot{robot[1]}.clf', '--map', 'm', '--robot', robot,
         '--out', f'{a.out}/{robot}', *extra, *speed], env=env, stdout=subprocess.DEVNULL,
        stderr=open(f'{a.out}/{robot}.err', 'w'))
    r1 = replay('r1', [])
    time.sleep(0.5)  # robot 1 defines the map frame
    r2 = replay('r2', ['--initial-pose', f'{at[0]:.4f},{at[1]:.4f},{at[2]:.5f}'])
    r1.wait(); r2.wait()
    session = json.loads(w('--json', 'map', 'show', 'm').stdout)['trajectories'][1]['session_id']
    follow = None
    deadline = time.time() + 300
    while time.time() < deadline and follow is None:
        found = re.search(re.escape(session) + r' \(closed\) followed to its last node: (.*)',
                          open(a.out + '/server.log').read())
        follow = found.group(1) if found else None
        time.sleep(0.5)
    w('slam', 'trajectory', session, '--frame', 'map', '--out', a.out + '/r2_map.txt')
    errors = [math.dist(p[:2], relative(start1, true2[t])[:2])
              for t, p in tum(a.out + '/r2_map.txt').items() if t in true2]
    print(json.dumps({'out': a.out, 'server_flags': server_flags, 'speed': a.speed,
                      'matched': len(errors),
                      'mean_m': round(sum(errors) / len(errors), 3) if errors else None,
                      'max_m': round(max(errors), 3) if errors else None, 'r2_follow': follow}))
finally:
    server.terminate()
    server.wait()
