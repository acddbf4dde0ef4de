#!/usr/bin/env bash
# The README's tour in one go: demo data from real 360-degree photos, a server on a free port with
# its own database, enroll, recognize, evaluate, stop.
set -euo pipefail
BUILD_DIR=${1:-build}
DEMO=${DEMO_DIR:-out/demo}
W="$BUILD_DIR/bin/waymark"
[ -d "$DEMO/db" ] || "$BUILD_DIR/bin/waymark-demo-data" "$DEMO"
rm -f "$DEMO/demo.db"*
"$BUILD_DIR/bin/waymark-server" --listen 127.0.0.1:0 --db "$DEMO/demo.db" --insecure-dev > "$DEMO/server.out" 2> "$DEMO/server.log" &
SERVER=$!
trap 'kill $SERVER 2>/dev/null; wait $SERVER 2>/dev/null || true' EXIT
for _ in $(seq 100); do grep -q "listening on" "$DEMO/server.out" && break; sleep 0.1; done
ADDR=$(sed -n 's/.*listening on //p' "$DEMO/server.out")
set -x
"$W" --server "$ADDR" db create demo
"$W" --server "$ADDR" enroll demo "$DEMO/db"
"$W" --server "$ADDR" recognize demo --verbose "$(ls "$DEMO"/query/city/*.jpg | head -1)"
"$W" --server "$ADDR" eval demo "$DEMO/query"
"$W" --server "$ADDR" eval demo "$DEMO/query" --mode verified
