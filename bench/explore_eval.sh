#!/usr/bin/env bash
# Active exploration vs wandering in the simulator (issue 4): every built-in world, both modes,
# several seeds, equal simulated time, through a real server on loopback. Writes one directory
# per run (maps, timelines, trajectories, summary.json) and a markdown table of
# mean [min, max] over the seeds.
#   bench/explore_eval.sh [BUILD_DIR]   env: OUT, SEEDS ("1 2 3"), DURATION (1200), PORT (50091)
set -euo pipefail
BUILD_DIR=${1:-build}
OUT=${OUT:-out/bench/explore}
SEEDS=${SEEDS:-"1 2 3"}
DURATION=${DURATION:-1200}
PORT=${PORT:-50091}
mkdir -p "$OUT"
"$BUILD_DIR/bin/waymark-server" --listen "127.0.0.1:$PORT" --db "$OUT/explore.db" --insecure-dev > "$OUT/server.log" 2>&1 &
SERVER=$!
trap 'kill $SERVER 2>/dev/null; wait $SERVER 2>/dev/null || true' EXIT
sleep 1
value() { sed -n "s/^ *\"$1\": \([^,]*\),\{0,1\}$/\1/p" "$2"; }
ROWS="$OUT/runs.tsv"
printf 'world\tmode\tseed\tcompleteness\tloc_error_mean_m\tloc_error_final_m\tcov_trace_mean\tcollisions\tdistance_m\twall_following_share\n' > "$ROWS"
for world in corridor loop office; do
  for mode in active wander; do
    for seed in $SEEDS; do
      dir="$OUT/$world-$mode-s$seed"
      "$BUILD_DIR/bin/waymark" --server "127.0.0.1:$PORT" sim explore --world "$world" \
        --mode "$mode" --duration "$DURATION" --seed "$seed" --out "$dir" --json > "$dir.json"
      printf '%s\t%s\t%s' "$world" "$mode" "$seed" >> "$ROWS"
      for key in completeness loc_error_mean_m loc_error_final_m cov_trace_mean collisions \
                 distance_m wall_following_share; do
        printf '\t%s' "$(value "$key" "$dir.json")" >> "$ROWS"
      done
      printf '\n' >> "$ROWS"
      echo "$world $mode seed $seed: completeness $(value completeness "$dir.json")"
    done
  done
done
# Mean [min, max] per world and mode.
awk -F'\t' -v duration="$DURATION" '
  NR == 1 { next }
  { key = $1 " | " $2; n[key]++; order[key] = NR
    for (c = 4; c <= 10; c++) { s[key, c] += $c
      if (!(key SUBSEP c in lo) || $c < lo[key, c]) lo[key, c] = $c
      if (!(key SUBSEP c in hi) || $c > hi[key, c]) hi[key, c] = $c } }
  END {
    printf "| world | mode | completeness | loc. error mean (m) | loc. error final (m) | mean cov. trace | collisions | distance (m) | wall following |\n"
    printf "|---|---|---|---|---|---|---|---|---|\n"
    PROCINFO["sorted_in"] = "@ind_str_asc"
    for (key in n) {
      printf "| %s |", key
      for (c = 4; c <= 10; c++) {
        if (c == 8) printf " %d |", s[key, c]
        else printf " %.3g [%.3g, %.3g] |", s[key, c] / n[key], lo[key, c], hi[key, c]
      }
      printf "\n"
    }
    printf "\n%d seeds per row, %s s simulated each.\n", n[key], duration
  }' "$ROWS" > "$OUT/table.md"
cat "$OUT/table.md"
