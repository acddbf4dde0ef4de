#!/usr/bin/env bash
# Issue 38: two follow settings judged on the same simulated robots (docs/results.md, "Tried, not
# kept: a jump only where staying is contradicted"). For each seed: two robots explore the
# `building` world live on a server with the default flags and are recorded
# (`waymark sim explore --record`); the recording is then replayed once per setting
# (sim_replay_ab.py) and robot 2's mean map-frame error printed, one line per seed and setting.
#
#   bench/shared_map/sim_ab_sweep.sh OUT "SEEDS" "FLAGS A" "FLAGS B" [BUILD] [SPEED]
#   bench/shared_map/sim_ab_sweep.sh /tmp/ab "1 2 3 4 5" "" "--slam-map-follow-windows wide"
#
# WORLD (default building) and PORT (default 51250) from the environment. Each seed takes about a
# minute to record and a minute per setting at SPEED 40 (the default) on a 2-core machine.
set -euo pipefail
[ $# -ge 4 ] || { sed -n 2,13p "$0" >&2; exit 2; }
OUT=$1; SEEDS=$2; FLAGS_A=$3; FLAGS_B=$4; BUILD=${5:-build}; SPEED=${6:-40}
WORLD=${WORLD:-building}; PORT=${PORT:-51250}
HERE=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$OUT"
for S in $SEEDS; do
  R="$OUT/s$S"
  mkdir -p "$R"
  if [ ! -f "$R/logs/robot2.clf" ]; then
    rm -f "$R"/w.db*
    "$BUILD/bin/waymark-server" --listen "127.0.0.1:$PORT" --db "$R/w.db" --insecure-dev \
      > "$R/server.log" 2>&1 &
    SERVER=$!
    sleep 1.5
    WAYMARK_SERVER="127.0.0.1:$PORT" "$BUILD/bin/waymark" map create m > /dev/null
    WAYMARK_SERVER="127.0.0.1:$PORT" "$BUILD/bin/waymark" sim explore --world "$WORLD" \
      --robots 2 --map m --seed "$S" --json --out "$R/run" --record "$R/logs" > "$R/run.json"
    kill "$SERVER"; wait "$SERVER" 2>/dev/null || true
  fi
  for SETTING in A B; do
    if [ "$SETTING" = A ]; then FLAGS=$FLAGS_A; else FLAGS=$FLAGS_B; fi
    # shellcheck disable=SC2086  # the flags are words
    LINE=$(python3 "$HERE/sim_replay_ab.py" "$R/logs" "$R/run" "$R/replay-$SETTING" \
             --build "$BUILD" --port "$((PORT + 1))" --speed "$SPEED" -- $FLAGS)
    echo "seed $S setting $SETTING ($FLAGS): $LINE"
  done
done
