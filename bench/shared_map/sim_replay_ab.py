#!/usr/bin/env python3
"""Issue 38: simulated robots, recorded once, followed with one server setting (docs/results.md,
"Tried, not kept: a jump only where staying is contradicted"). A second live `sim explore` run
cannot compare two settings: the server's answers steer the robots, so their paths part. Here
every robot's recorded log (`waymark sim explore --robots N --map M --record REC --out RUN`,
known starts) is replayed at once into a new map on a fresh waymark-server with the given flags,
each robot after the first at its true start in robot 1's frame, and each one's map-frame
trajectory is scored against its true one.

  sim_replay_ab.py REC RUN OUT [--build build] [--port 51230] [--speed 40] [-- SERVER FLAGS...]

--speed: both replays at the simulation's pace times this (0: as fast as the server answers; the
follow then catches up after the replays, against robot 1's whole map, which is not what a live
run meets). Prints one JSON line: robot 2's poses matched to the truth, their mean and largest
position error (m), and the server's "followed to its last node" counts for robot 2; the same
for every robot after the first under "robots"."""
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
    count = len([f for f in os.listdir(a.rec) if re.fullmatch(r'robot\d+\.clf', f)])
    truth = {k: tum(f'{a.run}/robot{k}/trajectory_true.txt') for k in range(1, count + 1)}
    start1 = truth[1][min(truth[1])]
    replay = lambda k, extra: subprocess.Popen(
        [W, 'slam', 'replay', f'{a.rec}/robot{k}.clf', '--map', 'm', '--robot', f'r{k}',
         '--out', f'{a.out}/r{k}', *extra, *speed], env=env, stdout=subprocess.DEVNULL,
        stderr=open(f'{a.out}/r{k}.err', 'w'))
    replays = [replay(1, [])]
    time.sleep(0.5)  # robot 1 defines the map frame
    for k in range(2, count + 1):
        at = relative(start1, truth[k][min(truth[k])])
        replays.append(replay(k, ['--initial-pose', f'{at[0]:.4f},{at[1]:.4f},{at[2]:.5f}']))
        time.sleep(0.3)  # the map's trajectories in the robots' order
    for r in replays:
        r.wait()
    trajectories = json.loads(w('--json', 'map', 'show', 'm').stdout)['trajectories']
    robots = {}
    for k in range(2, count + 1):
        session = trajectories[k - 1]['session_id']
        follow = None
        deadline = time.time() + 300
        while time.time() < deadline and follow is None:
            found = re.search(re.escape(session) + r' \(closed\) followed to its last node: (.*)',
                              open(a.out + '/server.log').read())
            follow = found.group(1) if found else None
            time.sleep(0.5)
        w('slam', 'trajectory', session, '--frame', 'map', '--out', f'{a.out}/r{k}_map.txt')
        errors = [math.dist(p[:2], relative(start1, truth[k][t])[:2])
                  for t, p in tum(f'{a.out}/r{k}_map.txt').items() if t in truth[k]]
        robots[f'r{k}'] = {'matched': len(errors),
                           'mean_m': round(sum(errors) / len(errors), 3) if errors else None,
                           'max_m': round(max(errors), 3) if errors else None, 'follow': follow}
    r2 = robots['r2']
    print(json.dumps({'out': a.out, 'server_flags': server_flags, 'speed': a.speed,
                      'matched': r2['matched'], 'mean_m': r2['mean_m'], 'max_m': r2['max_m'],
                      'r2_follow': r2['follow'], 'robots': robots}))
finally:
    server.terminate()
    server.wait()
