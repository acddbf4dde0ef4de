#!/usr/bin/env python3
"""Issue 38 (docs/results.md, "One pose graph for the whole map"): one run of split_robots.py,
its stored map served again by waymark-server with each placement of the map's trajectories, so
that both are scored on the very same follow samples. For each of --flags (a server flag and
its values, default --slam-map-graph false and true) prints the relations error of every robot
alone and of the merged map-frame trajectory (r1's poses first, then r2's, ...), as one JSON line.

  placement_compare.py RUNDIR RELATIONS [--build build] [--port 50971]

RUNDIR: split_robots.py's --out (its w.db). The database is copied; the run is not changed."""
import argparse, json, os, shutil, subprocess, sys, tempfile, time

p = argparse.ArgumentParser()
p.add_argument('run')
p.add_argument('relations')
p.add_argument('--build', default='build')
p.add_argument('--port', default='50971')
p.add_argument('--flag', default='--slam-map-graph')
p.add_argument('--values', default='false,true')
a = p.parse_args()
bin_dir = os.path.join(a.build, 'bin')
work = tempfile.mkdtemp(prefix='placement-')


def relations_error(path):
    run = subprocess.run([os.path.join(bin_dir, 'waymark'), 'eval', 'relations', path, a.relations,
                          '--json'], capture_output=True, text=True, check=True)
    return round(json.loads(run.stdout)['trans_abs_mean'], 4)


out = {}
for value in a.values.split(','):
    db = os.path.join(work, 'w.db')
    shutil.copy(os.path.join(a.run, 'w.db'), db)
    # The tie is off: the stored ties and samples are what is placed, nothing new is searched.
    server = subprocess.Popen([os.path.join(bin_dir, 'waymark-server'), '--listen',
                               '127.0.0.1:' + a.port, '--db', db, '--insecure-dev',
                               f'{a.flag}={value}', '--slam-map-tie=false'],
                              stdout=open(db + '.log', 'w'), stderr=subprocess.STDOUT)
    try:
        env = dict(os.environ, WAYMARK_SERVER='127.0.0.1:' + a.port)
        for _ in range(100):
            shown = subprocess.run([os.path.join(bin_dir, 'waymark'), '--json', 'map', 'show', 'm'],
                                   env=env, capture_output=True, text=True)
            if shown.returncode == 0:
                break
            time.sleep(0.1)
        ids = [t['session_id'] for t in json.loads(shown.stdout)['trajectories']]
        merged, result = {}, {}
        # r1's poses win where robots overlap, then r2's, ... (as split_robots.py merges them).
        for k, session in reversed(list(enumerate(ids))):
            path = os.path.join(work, f'{value}-r{k + 1}.txt')
            subprocess.run([os.path.join(bin_dir, 'waymark'), 'slam', 'trajectory', session,
                            '--frame', 'map', '--out', path], env=env, capture_output=True,
                           check=True)
            result[f'r{k + 1}'] = relations_error(path)
            for line in open(path):
                if line.strip() and not line.startswith('#'):
                    merged[line.split()[0]] = line
        path = os.path.join(work, f'{value}-merged.txt')
        with open(path, 'w') as f:
            f.write('# t x y z qx qy qz qw\n')
            for stamp in sorted(merged, key=float):
                f.write(merged[stamp])
        result['merged'] = relations_error(path)
        out[f'{a.flag}={value}'] = result
    finally:
        server.terminate()
        server.wait()
print(json.dumps(out))
shutil.rmtree(work)
