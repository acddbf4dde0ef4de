#!/usr/bin/env bash
# Exploration modes compared in the simulator (issues 4 and 17): every world x mode x seed, equal
# simulated time, through one real server on loopback, JOBS runs at a time (each run is its own
# session, independent of the others). Writes per run OUT/<world>-<mode>-s<seed>/ (maps,
# timelines, trajectories, summary.json), its --json summary beside it (.json) and its stderr
# (.log); then OUT/runs.tsv (one row per run) and OUT/table.md (per world and mode over the seeds).
#   bench/laser/explore_eval.sh [BUILD_DIR]
#   env: OUT (out/bench/explore), WORLDS ("corridor loop office building cluttered"),
#        MODES ("active wander frontier"), SEEDS ("1 2 3 4 5"), DURATION (1800 s), JOBS (2),
#        PORT (50091)
# A summary key the binary does not report (an older build) and a failed run show as "-".
set -euo pipefail
BUILD_DIR=${1:-build}
OUT=${OUT:-out/bench/explore}
WORLDS=${WORLDS:-"corridor loop office building cluttered"}
MODES=${MODES:-"active wander frontier"}
SEEDS=${SEEDS:-"1 2 3 4 5"}
DURATION=${DURATION:-1800}
JOBS=${JOBS:-2}
PORT=${PORT:-50091}
WAYMARK="$BUILD_DIR/bin/waymark"
SERVER_ADDRESS="127.0.0.1:$PORT"
# The summary keys runs.tsv keeps, in its column order (after world, mode, seed and exit).
KEYS=(completeness completeness_visible completeness_300s completeness_600s completeness_1200s
  time_to_95_s done_time_s
  final_state distance_m loc_error_mean_m loc_error_final_m cov_trace_mean collisions
  planning_ms_p50 planning_ms_p99 sim_time_s)

mkdir -p "$OUT"
"$BUILD_DIR/bin/waymark-server" --listen "$SERVER_ADDRESS" --db "$OUT/explore.db" --insecure-dev \
  > "$OUT/server.log" 2>&1 &
SERVER=$!
trap 'kill $SERVER 2>/dev/null; wait $SERVER 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  "$WAYMARK" --server "$SERVER_ADDRESS" --timeout 1 health > /dev/null 2>&1 && break
  kill -0 $SERVER 2>/dev/null || { echo "server did not start: see $OUT/server.log" >&2; exit 1; }
  sleep 0.1
done

# One run; never fails (a failed run is reported and its row shows "-"), so that the others go on.
run() {
  local name="$1-$2-s$3" status=0
  "$WAYMARK" --server "$SERVER_ADDRESS" --json sim explore --world "$1" --mode "$2" \
    --duration "$DURATION" --seed "$3" --out "$OUT/$name" > "$OUT/$name.json" \
    2> "$OUT/$name.log" || status=$?
  echo "$status" > "$OUT/$name.exit"
  if [ "$status" -ne 0 ]; then
    echo "$name: FAILED (exit $status, see $OUT/$name.log)"
  else
    echo "$name: completeness $(summary_values "$OUT/$name.json" completeness)"
  fi
}

# The top-level values of the keys ($2...) in a summary (nlohmann dump(2): one "key": value a line,
# two spaces in), tab-separated; "-" for a key that is missing or null (a NaN).
summary_values() {
  local file="$1"
  shift
  awk -v keys="$*" '
    /^  "[^"]*": / {
      key = $0; sub(/^  "/, "", key); sub(/".*/, "", key)
      value = $0; sub(/^  "[^"]*": /, "", value); sub(/,$/, "", value); gsub(/"/, "", value)
      found[key] = value }
    END {
      n = split(keys, k, " ")
      for (i = 1; i <= n; i++) {
        value = (k[i] in found) && found[k[i]] != "null" ? found[k[i]] : "-"
        printf "%s%s", (i > 1 ? "\t" : ""), value }
      printf "\n" }' "$file"
}

# In a subshell, whose only children are the runs: the server is not among what `wait` waits for.
(
  running=0
  for world in $WORLDS; do
    for mode in $MODES; do
      for seed in $SEEDS; do
        if [ "$running" -ge "$JOBS" ]; then
          wait -n
          running=$((running - 1))
        fi
        run "$world" "$mode" "$seed" &
        running=$((running + 1))
      done
    done
  done
  wait
)

# Rows in world, mode, seed order, whatever order the runs finished in.
ROWS="$OUT/runs.tsv"
(IFS=$'\t'; echo "world${IFS}mode${IFS}seed${IFS}exit${IFS}${KEYS[*]}") > "$ROWS"
for world in $WORLDS; do
  for mode in $MODES; do
    for seed in $SEEDS; do
      name="$world-$mode-s$seed"
      printf '%s\t%s\t%s\t%s\t%s\n' "$world" "$mode" "$seed" "$(cat "$OUT/$name.exit")" \
        "$(summary_values "$OUT/$name.json" "${KEYS[@]}")" >> "$ROWS"
    done
  done
done

# Per world and mode (in the order asked for: plain awk has no sorted iteration): mean [min, max]
# over the seeds; times to 0.95 and to DONE as the mean over the seeds that got there and how
# many did; collisions summed; planning times the median of the seeds' percentiles.
awk -F'\t' -v worlds="$WORLDS" -v modes="$MODES" -v seeds="$SEEDS" -v duration="$DURATION" '
  function number(x) { return x != "-" && x != "" }
  function show(x) { return (x >= 100 || x <= -100) ? sprintf("%.0f", x) : sprintf("%.3g", x) }
  function spread(key, c) {
    if (!cnt[key, c]) return "-"
    return show(sum[key, c] / cnt[key, c]) " [" show(lo[key, c]) ", " show(hi[key, c]) "]" }
  # Mean over the seeds that got there (the time is -1 when a run never did) and how many did.
  function reached(key, c) {
    if (!cnt[key, c]) return "-"
    return (hit[key, c] ? show(hitsum[key, c] / hit[key, c]) : "-") " (" hit[key, c] "/" cnt[key, c] ")" }
  function median(key, c,   i, j, t, m, v) {
    m = cnt[key, c]
    if (!m) return "-"
    for (i = 1; i <= m; i++) v[i] = val[key, c, i]
    for (i = 2; i <= m; i++)
      for (j = i; j > 1 && v[j - 1] > v[j]; j--) { t = v[j]; v[j] = v[j - 1]; v[j - 1] = t }
    return show(m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2) }
  NR == 1 { for (c = 1; c <= NF; c++) col[$c] = c; next }
  { key = $1 SUBSEP $2; runs[key]++; ok[key] += $4 == 0
    for (c = 5; c <= NF; c++) {
      if (!number($c)) continue
      x = $c + 0; m = ++cnt[key, c]; val[key, c, m] = x; sum[key, c] += x
      if (m == 1 || x < lo[key, c]) lo[key, c] = x
      if (m == 1 || x > hi[key, c]) hi[key, c] = x
      if (x >= 0) { hit[key, c]++; hitsum[key, c] += x } } }
  END {
    printf "| world | mode | runs | completeness 300 s | 600 s | 1200 s | end | of the visible |"
    printf " time to 0.95 (s) |"
    printf " time to DONE (s) | distance (m) | loc. error mean (m) | loc. error final (m) |"
    printf " mean cov. trace | collisions | planning p50 / p99 (ms) |\n"
    printf "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    nw = split(worlds, W, " "); nm = split(modes, M, " ")
    for (i = 1; i <= nw; i++) for (j = 1; j <= nm; j++) {
      key = W[i] SUBSEP M[j]
      if (!(key in runs)) continue
      collisions = cnt[key, col["collisions"]] ? sprintf("%d", sum[key, col["collisions"]]) : "-"
      printf "| %s | %s | %d/%d | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s / %s |\n",
        W[i], M[j], ok[key], runs[key],
        spread(key, col["completeness_300s"]), spread(key, col["completeness_600s"]),
        spread(key, col["completeness_1200s"]), spread(key, col["completeness"]),
        spread(key, col["completeness_visible"]),
        reached(key, col["time_to_95_s"]), reached(key, col["done_time_s"]),
        spread(key, col["distance_m"]), spread(key, col["loc_error_mean_m"]),
        spread(key, col["loc_error_final_m"]), spread(key, col["cov_trace_mean"]), collisions,
        median(key, col["planning_ms_p50"]), median(key, col["planning_ms_p99"])
    }
    printf "\nmean [min, max] over the seeds (%s), %s s simulated each; runs: finished/started.\n",
      seeds, duration
    printf "Of the visible: completeness at the end over only the wall length that can be seen at all.\n"
    printf "Times to 0.95 completeness and to DONE: mean over the runs that got there (how many did).\n"
    printf "Collisions: sum over the seeds. Planning: median over the seeds of each run'"'"'s percentile.\n"
  }' "$ROWS" > "$OUT/table.md"
cat "$OUT/table.md"
