#!/usr/bin/env python3
"""Issue 38 on a fleet (docs/results.md, "A robot on another server, as its nodes come"): how far
behind the map's owner sees a robot that streams to another server, with the node feed
(--slam-map-feed-seconds, trajectory_feed.h) and without it (the robot's checkpoints only, every
--slam-checkpoint-seconds or --slam-checkpoint-scans), and when a second robot is tied in.

Two waymark-servers, A and B, on one PostgreSQL database (tests/support/postgres_server.sh makes
a throwaway cluster). Robot r1 replays scans FIRST1:LAST1 of LOG at the log's pace into map
"fleet" on A; after --delay seconds robot r2 replays FIRST2:LAST2 on B, with no start pose. B
owns the map (it has the robot to tie in) and reads r1 from A: every second the script reads
from the database how many of r1's scans the owner can see (the feed's scans_processed, or the
checkpoint's) and, from the log's stamps, how many seconds of r1's driving that is behind.

  fleet_feed.py LOG --r1 0:1200 --r2 400:1600 --delay 90 --feed-seconds 1 --out DIR [--build build]

Prints one JSON line: lag_s (median, 90th percentile and largest over r1's replay after r2
started; the owner's view of r1 in seconds of r1's clock behind r1), r2's tie (tied_at_scan and
seconds of its own clock after its first node, from B's log) and the flags."""
import argparse, bz2, gzip, json, os, re, signal, subprocess, sys, time

p = argparse.ArgumentParser()
p.add_argument('log')
p.add_argument('--r1', required=True)
p.add_argument('--r2', required=True)
p.add_argument('--delay', type=float, required=True)
p.add_argument('--feed-seconds', type=float, required=True, help='0: the checkpoints only')
p.add_argument('--out', required=True)
p.add_argument('--build', default='build')
p.add_argument('--ports', default='50981,50982')
a = p.parse_args()
here = os.path.dirname(os.path.abspath(__file__))
repo = os.path.dirname(os.path.dirname(here))
W = os.path.join(a.build, 'bin', 'waymark')
SERVER = os.path.join(a.build, 'bin', 'waymark-server')
os.makedirs(a.out, exist_ok=True)
pg_state = os.path.join(os.path.abspath(a.out), 'pg')
os.makedirs(pg_state, exist_ok=True)
PG = os.path.join(repo, 'tests', 'support', 'postgres_server.sh')


def opener(path):
    return bz2.open if path.endswith('.bz2') else gzip.open if path.endswith('.gz') else open


stamps = [float(line.split()[-3]) for line in opener(a.log)(a.log, 'rt')
          if line.startswith('FLASER')]
first1, last1 = map(int, a.r1.split(':'))

subprocess.run([PG, 'start', pg_state], check=True)
uri = open(os.path.join(pg_state, 'uri')).read().strip()


def psql(sql):
    r = subprocess.run(['psql', uri, '-At', '-c', sql], capture_output=True, text=True)
    return r.stdout.strip()


servers, logs = [], []
ports = a.ports.split(',')
try:
    for name, port in zip('AB', ports):
        log = open(os.path.join(a.out, f'server-{name}.log'), 'w')
        logs.append(log)
        servers.append(subprocess.Popen(
            [SERVER, '--db', uri, '--listen', f'127.0.0.1:{port}', '--insecure-dev',
             '--session-lease-seconds', '10',
             '--slam-map-feed-seconds', str(a.feed_seconds)], stdout=log, stderr=subprocess.STDOUT))
    env_a = dict(os.environ, WAYMARK_SERVER=f'127.0.0.1:{ports[0]}')
    env_b = dict(os.environ, WAYMARK_SERVER=f'127.0.0.1:{ports[1]}')
    for _ in range(100):
        if subprocess.run([W, 'map', 'list'], env=env_a, capture_output=True).returncode == 0:
            break
        time.sleep(0.2)
    subprocess.run([W, 'map', 'create', 'fleet'], env=env_a, check=True, capture_output=True)
    replay = lambda env, robot, scans: subprocess.Popen(
        [W, 'slam', 'replay', a.log, '--map', 'fleet', '--scans', scans, '--realtime', '--robot',
         robot, '--out', os.path.join(a.out, robot)], env=env, stdout=subprocess.DEVNULL,
        stderr=open(os.path.join(a.out, f'{robot}.err'), 'w'))
    start = time.time()
    r1 = replay(env_a, 'r1', a.r1)
    r2 = None
    lags = []
    while r1.poll() is None:
        now = time.time() - start
        if r2 is None and now >= a.delay:
            r2 = replay(env_b, 'r2', a.r2)
        if r2 is not None:
            sql = ("SELECT f.scans_processed FROM slam_map_feed f JOIN slam_session s ON "
                   "s.id = f.session_id WHERE s.robot_id = 'r1'" if a.feed_seconds > 0 else
                   "SELECT scans_processed FROM slam_session WHERE robot_id = 'r1'")
            seen = psql(sql)
            seen = int(seen) if seen else 0
            # r1's clock now (the replay keeps the log's pace from its first scan) against the
            # stamp of the newest scan the owner can see.
            clock = stamps[first1] + now
            seen_clock = stamps[min(first1 + seen, last1) - 1] if seen > 0 else stamps[first1]
            if clock <= stamps[last1 - 1]:
                lags.append(round(clock - seen_clock, 2))
        time.sleep(1.0)
    if r2 is not None:
        r2.wait(timeout=3600)
    time.sleep(5)
finally:
    for s in servers:
        s.send_signal(signal.SIGTERM)
    for s in servers:
        try:
            s.wait(timeout=60)
        except subprocess.TimeoutExpired:
            s.kill()
    subprocess.run([PG, 'stop', pg_state])

tie = None
for name in 'AB':
    for line in open(os.path.join(a.out, f'server-{name}.log')):
        m = re.search(r'tied in at \(([-\d.]+), ([-\d.]+), ([-\d.]+)\) at its scan (\d+) \(([\d.]+) s '
                      r'after its first node', line)
        if m:
            tie = {'server': name, 'tie': [float(m.group(i)) for i in (1, 2, 3)],
                   'tied_at_scan': int(m.group(4)), 'tied_after_s': float(m.group(5))}
lags.sort()
pick = lambda q: lags[min(len(lags) - 1, int(q * len(lags)))] if lags else None
print(json.dumps({'log': os.path.basename(a.log), 'r1': a.r1, 'r2': a.r2, 'delay_s': a.delay,
                  'feed_seconds': a.feed_seconds, 'lag_samples': len(lags),
                  'lag_median_s': pick(0.5), 'lag_p90_s': pick(0.9),
                  'lag_max_s': lags[-1] if lags else None, 'r2_tie': tie}))
