#!/usr/bin/env bash
# Crash safety of enrollment (issue 6): a server bulk-enrolls (`waymark enroll` is one BulkEnroll
# stream per run, repeated until the server dies) and is killed with SIGKILL at a random moment.
# Then, before anything else opens the file, it must be intact and hold no half-enrolled view:
#   - PRAGMA integrity_check is "ok" and PRAGMA foreign_key_check finds nothing;
#   - every view belongs to exactly one cluster of its own database, and its feature blobs have
#     the sizes its counts say; every cluster contains its centre; no crossing is without views
#     (a crossing is created in the transaction of its first view);
#   - no view committed before this trial is lost.
# Then the server restarts on the file and must serve exactly the views the file holds.
# TRIALS rounds (default 20) on one growing database.
#
#   bench/robustness/enroll_crash.sh [BUILD_DIR]
#   env: TRIALS=20  OUT=out/bench/enroll_crash  SEED=<random>  IMAGES=<dir with db/<crossing>/...>
# Needs python3 (its sqlite3 module reads the file) and the images: by default the demo data that
# waymark-demo-data cuts from the Debian package blender-data (60 views of 5 places).
set -euo pipefail
BUILD_DIR=${1:-build}
TRIALS=${TRIALS:-20}
OUT=${OUT:-out/bench/enroll_crash}
SEED=${SEED:-$$}
W="$BUILD_DIR/bin/waymark"
S="$BUILD_DIR/bin/waymark-server"
mkdir -p "$OUT"
IMAGES=${IMAGES:-$OUT/images}
if [ ! -d "$IMAGES/db" ]; then
  "$BUILD_DIR/bin/waymark-demo-data" "$IMAGES" > "$OUT/demo-data.log" 2>&1 \
    || { cat "$OUT/demo-data.log" >&2; exit 1; }
fi
DB="$OUT/crash.db"
rm -f "$DB" "$DB-wal" "$DB-shm" "$DB.lock" "$OUT/server.log" "$OUT/trials.jsonl"
RANDOM=$SEED

SERVER=""
ENROLLER=""
cleanup() {
  [ -n "$ENROLLER" ] && kill "$ENROLLER" 2> /dev/null || true
  [ -n "$SERVER" ] && kill "$SERVER" 2> /dev/null || true
  wait 2> /dev/null || true
}
trap cleanup EXIT

start_server() {
  : > "$OUT/server.out"
  "$S" --listen 127.0.0.1:0 --db "$DB" --insecure-dev > "$OUT/server.out" 2>> "$OUT/server.log" &
  SERVER=$!
  for _ in $(seq 300); do
    grep -q "listening on" "$OUT/server.out" && break
    kill -0 "$SERVER" 2> /dev/null || { echo "server exited; see $OUT/server.log" >&2; exit 1; }
    sleep 0.1
  done
  ADDR=$(sed -n 's/.*listening on //p' "$OUT/server.out")
  [ -n "$ADDR" ] || { echo "server did not listen within 30 s" >&2; exit 1; }
}

# Prints the file's checks as one JSON object; exits 1 when any fails.
check_file() {
  python3 - "$DB" << 'PY'
import json, sqlite3, sys
con = sqlite3.connect(sys.argv[1])
one = lambda sql: con.execute(sql).fetchone()[0]
result = {
    "integrity_check": one("PRAGMA integrity_check"),
    "foreign_key_violations": len(con.execute("PRAGMA foreign_key_check").fetchall()),
    "views": one("SELECT COUNT(*) FROM view"),
    "clusters": one("SELECT COUNT(*) FROM cluster"),
    # A view in no cluster, or in two, or in a cluster of another database.
    "views_not_in_exactly_one_cluster": one(
        "SELECT COUNT(*) FROM view v JOIN crossing x ON x.id = v.crossing_id WHERE "
        "(SELECT COUNT(*) FROM cluster_member m JOIN cluster c ON c.id = m.cluster_id "
        " WHERE m.view_id = v.id AND c.db_id = x.db_id) != 1 OR "
        "(SELECT COUNT(*) FROM cluster_member m WHERE m.view_id = v.id) != 1"),
    # Blob sizes against their counts: 6 float32 per keypoint, 128 bytes per descriptor.
    "views_with_inconsistent_features": one(
        "SELECT COUNT(*) FROM view WHERE length(keypoints) != keypoint_count * 24 "
        "OR length(descriptors) != keypoint_count * 128 OR length(hue_hist) != hue_bins * 4 "
        "OR keypoint_count < 10"),
    "clusters_without_their_centre": one(
        "SELECT COUNT(*) FROM cluster c WHERE NOT EXISTS (SELECT 1 FROM cluster_member m "
        "WHERE m.cluster_id = c.id AND m.view_id = c.center_view_id)"),
    "crossings_without_views": one(
        "SELECT COUNT(*) FROM crossing c WHERE NOT EXISTS "
        "(SELECT 1 FROM view v WHERE v.crossing_id = c.id)"),
}
bad = [k for k, v in result.items()
       if (k == "integrity_check" and v != "ok") or
          (k not in ("integrity_check", "views", "clusters") and v != 0)]
result["ok"] = not bad
print(json.dumps(result))
sys.exit(1 if bad else 0)
PY
}

json_field() { python3 -c "import json,sys; print(json.load(sys.stdin)$1)"; }

start_server
"$W" --server "$ADDR" db create crash > /dev/null
failures=0
previous=0
for trial in $(seq "$TRIALS"); do
  # Kill somewhere in the first 4 s of enrolling (one pass over the demo views takes about 2 s
  # here, so kills land in every phase: mid-stream, between streams, at the very start).
  delay_ms=$((200 + RANDOM % 3800))
  (while "$W" --server "$ADDR" --timeout 0 enroll crash "$IMAGES/db" > /dev/null 2>&1; do :; done) &
  ENROLLER=$!
  sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
  kill -9 "$SERVER"
  wait "$SERVER" 2> /dev/null || true
  SERVER=""
  wait "$ENROLLER" 2> /dev/null || true  # its stream broke with the server
  ENROLLER=""

  ok=true
  file=$(check_file) || ok=false
  views=$(echo "$file" | json_field '["views"]')
  [ "$views" -ge "$previous" ] || ok=false  # nothing committed before is lost

  start_server
  served=$("$W" --server "$ADDR" --json db stats crash | json_field '["database"]["views"]')
  [ "$served" -eq "$views" ] || ok=false

  echo "{\"trial\": $trial, \"kill_after_ms\": $delay_ms, \"views_before\": $previous," \
       "\"views_after\": $views, \"served_after_restart\": $served, \"ok\": $ok, \"file\": $file}" \
    | tee -a "$OUT/trials.jsonl"
  $ok || failures=$((failures + 1))
  previous=$views
done
echo "$TRIALS trials, $failures failed (seed $SEED); per trial: $OUT/trials.jsonl"
[ "$failures" -eq 0 ]
