#!/usr/bin/env bash
# Waymark's laser SLAM beside MRPT's icp-slam on the same CARMEN logs, in one run, scored with the
# same metric (`waymark eval relations`, Kummerle et al. 2009) and timed with the same clock.
#
#   bench/laser/laser_peer_mrpt.sh BUILD_DIR [options] [LOG...]
#     LOG        CARMEN log (plain, .gz, .bz2); scored when LOG's folder holds NAME.relations
#                (NAME = file name without .clf/.log and compression); otherwise run and timed only.
#                Default: ACES and Intel from ../shared/data/laser.
#     --out DIR  results (default out/bench/laser_peer_mrpt): table.md, results.json, runs.tsv,
#                summary.tsv, and per log / method / run the trajectory (TUM) and the tools' logs
#     --json FILE  also write the results JSON there
#     --repeat N   runs of each method per log (default 1); the table shows medians
#     --methods LIST  comma-separated, default waymark,mrpt-icp-shipped,mrpt-icp-tuned
#   env: SHARED (default ../shared beside the repository), MRPT_INI (icp-slam's example config,
#        default from Debian's mrpt-common), KEEP_TMP=1 keeps the temporary folder
#
# Methods:
#   waymark           `waymark slam replay LOG` against a waymark-server started here (loopback,
#                     free port, --insecure-dev, a temporary SQLite file); the server's defaults.
#   mrpt-icp-shipped  MRPT 2.5 icp-slam with its example icp-slam_demo_classic.ini unchanged but
#                     for the 3-D window, scene files and per-step INFO lines (../shared/peers/MRPT.md).
#   mrpt-icp-tuned    the same plus MRPT.md's best settings of a 16-setting sweep.
# MRPT reads the log through carmen2rawlog with four workarounds (laser_peer_mrpt/
# carmen_for_mrpt.sh); its pose after every scan is exported at the scan's CARMEN stamp.
# Wall and CPU time: the replay command for Waymark (it reads the compressed log itself; CPU adds
# the server's), icp-slam alone for MRPT (the conversion is timed apart, in results.json).
# Needs mrpt-apps and mrpt-common: `scripts/install-deps.sh --peers` (`make peers-deps`), which this
# script runs when icp-slam, carmen2rawlog or the example config is missing.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
TOOLS="$HERE/laser_peer_mrpt"
die() { echo "laser_peer_mrpt: $*" >&2; exit 1; }
usage() { sed -n '/^#   bench/,/^# Methods/p' "$0" | sed '$d; s/^# \{0,1\}//' >&2; exit 2; }

[ $# -ge 1 ] || usage
case "$1" in -h|--help) usage ;; esac
BUILD_DIR=$1; shift
OUT=out/bench/laser_peer_mrpt
JSON=""
REPEAT=1
METHODS=waymark,mrpt-icp-shipped,mrpt-icp-tuned
LOGS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --out) OUT=$2; shift 2 ;;
    --json) JSON=$2; shift 2 ;;
    --repeat) REPEAT=$2; shift 2 ;;
    --methods) METHODS=$2; shift 2 ;;
    -h|--help) usage ;;
    -*) echo "unknown option $1" >&2; usage ;;
    *) LOGS+=("$1"); shift ;;
  esac
done
[[ "$REPEAT" =~ ^[1-9][0-9]*$ ]] || die "--repeat wants a positive integer, not '$REPEAT'"
IFS=, read -r -a METHOD_LIST <<< "$METHODS"
NEED_MRPT=0
for m in "${METHOD_LIST[@]}"; do
  case "$m" in
    waymark) ;;
    mrpt-icp-shipped|mrpt-icp-tuned) NEED_MRPT=1 ;;
    *) die "unknown method '$m' (waymark, mrpt-icp-shipped, mrpt-icp-tuned)" ;;
  esac
done
SHARED=${SHARED:-$(cd "$HERE/../../.." && pwd)/shared}
if [ ${#LOGS[@]} -eq 0 ]; then
  LOGS=("$SHARED/data/laser/aces/aces.clf.bz2" "$SHARED/data/laser/intel/intel.clf.bz2")
fi

# --- tools -----------------------------------------------------------------------------------
W="$BUILD_DIR/bin/waymark"
[ -x "$W" ] || die "missing $W (build it: cmake --build $BUILD_DIR --target waymark)"
if [[ ",$METHODS," == *,waymark,* ]]; then
  [ -x "$BUILD_DIR/bin/waymark-server" ] \
    || die "missing $BUILD_DIR/bin/waymark-server (build it: cmake --build $BUILD_DIR --target waymark-server)"
fi
MRPT_INI=${MRPT_INI:-/usr/share/mrpt/config_files/icp-slam/icp-slam_demo_classic.ini}
# icp-slam and carmen2rawlog are in mrpt-apps, the example config in mrpt-common.
# Missing ones are installed by the project's opt-in (scripts/install-deps.sh --peers, which is
# `make peers-deps`: Debian 12 packages, idempotent; it needs root or sudo).
if [ "$NEED_MRPT" -eq 1 ] && ! { command -v icp-slam && command -v carmen2rawlog && [ -f "$MRPT_INI" ]; } > /dev/null; then
  echo "== installing MRPT for the peers: scripts/install-deps.sh --peers"
  "$HERE/../../scripts/install-deps.sh" --peers \
    || die "scripts/install-deps.sh --peers failed (run it as root, or apt-get install mrpt-apps mrpt-common)"
  command -v icp-slam > /dev/null || die "icp-slam not found: scripts/install-deps.sh --peers (mrpt-apps)"
  command -v carmen2rawlog > /dev/null || die "carmen2rawlog not found: scripts/install-deps.sh --peers (mrpt-apps)"
  [ -f "$MRPT_INI" ] || die "$MRPT_INI not found: scripts/install-deps.sh --peers (mrpt-common), or set MRPT_INI"
fi
for log in "${LOGS[@]}"; do
  [ -f "$log" ] || die "no log $log"
  case "$log" in
    *.bz2) command -v bzip2 > /dev/null || die "bzip2 not found (for $log)" ;;
    *.gz) command -v gzip > /dev/null || die "gzip not found (for $log)" ;;
  esac
done

# --- temporary folder and server -------------------------------------------------------------
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
TMP=$(mktemp -d "${TMPDIR:-/tmp}/laser_peer_mrpt.XXXXXX")
SERVER=""
cleanup() {
  if [ -n "$SERVER" ]; then kill "$SERVER" 2> /dev/null || true; wait "$SERVER" 2> /dev/null || true; fi
  if [ "${KEEP_TMP:-0}" = 1 ]; then echo "temporary files kept in $TMP"; else rm -rf "$TMP"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

ADDR=""
if [[ ",$METHODS," == *,waymark,* ]]; then
  "$BUILD_DIR/bin/waymark-server" --listen 127.0.0.1:0 --db "$TMP/waymark.db" --insecure-dev \
    > "$TMP/server.out" 2> "$OUT/server.log" &
  SERVER=$!
  for _ in $(seq 300); do
    grep -q "listening on" "$TMP/server.out" && break
    kill -0 "$SERVER" 2> /dev/null || die "waymark-server exited; see $OUT/server.log"
    sleep 0.1
  done
  ADDR=$(sed -n 's/.*listening on //p' "$TMP/server.out")
  [ -n "$ADDR" ] || die "waymark-server did not listen within 30 s; see $OUT/server.log"
  echo "== waymark-server on $ADDR (database in $TMP)"
fi

# --- one run of one method -------------------------------------------------------------------
# Each runner prints "WALL CPU" in seconds. CPU (user + system) is steadier than wall time on a
# shared machine; for Waymark it is the replay client's plus the server's.
now() { echo "$EPOCHREALTIME"; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", b - a }'; }
value() { sed -n "s/^ *\"$1\": \([^,]*\),\{0,1\}$/\1/p" "$2"; }
# children_cpu VAR: VAR = CPU seconds of this shell's finished children. `times` must run in this
# shell, not in a pipe or $(...), whose fresh subshell has no children yet.
children_cpu() {
  local file="$TMP/times.$BASHPID"
  times > "$file"
  printf -v "$1" '%s' "$(awk 'function s(t) { sub(/s$/, "", t); split(t, p, "m"); return p[1] * 60 + p[2] }
    NR == 2 { printf "%.3f", s($1) + s($2) }' "$file")"
}
# CPU seconds a running process has used so far (fields 14, 15 of /proc/PID/stat, in ticks).
process_cpu() { awk -v hz="$(getconf CLK_TCK)" '{ printf "%.3f", ($14 + $15) / hz }' "/proc/$1/stat"; }

# run_waymark LOG DIR: DIR/trajectory.txt (and the replay's map, summary.json). A map whose
# self-check fails is still scored (its verdict is in summary.json): --allow-inconsistent-map.
run_waymark() {
  local start cpu0 cpu1 server0 end
  children_cpu cpu0; server0=$(process_cpu "$SERVER"); start=$(now)
  "$W" --server "$ADDR" slam replay "$1" --out "$2" --allow-inconsistent-map > "$2/replay.log" 2>&1 ||
    return 1
  end=$(now); children_cpu cpu1
  echo "$(elapsed "$start" "$end") $(awk -v a="$cpu0" -v b="$cpu1" -v c="$server0" \
    -v d="$(process_cpu "$SERVER")" 'BEGIN { printf "%.3f", b - a + d - c }')"
}

# run_icp PRESET CONVERTED DIR: icp-slam on CONVERTED/mrpt.rawlog, DIR/trajectory.txt.
run_icp() {
  local preset=$1 converted=$2 dir=$3 start cpu0 cpu1 end
  local icp_out="$TMP/icp-$preset"
  "$TOOLS/icp_slam_ini.sh" "$MRPT_INI" "$preset" "$icp_out" > "$dir/icp-slam.ini" || return 1
  children_cpu cpu0; start=$(now)
  icp-slam "$dir/icp-slam.ini" "$converted/mrpt.rawlog" < /dev/null > "$dir/icp-slam.log" 2>&1 || return 1
  end=$(now); children_cpu cpu1
  echo "$(elapsed "$start" "$end") $(elapsed "$cpu0" "$cpu1")"
  awk -f "$TOOLS/icp_path_to_tum.awk" "$converted/stamps.txt" "$icp_out/log_estimated_path.txt" \
    > "$dir/trajectory.txt" 2>> "$dir/icp-slam.log" || return 1
}

RUNS="$OUT/runs.tsv"
CONVERSIONS="$OUT/conversions.tsv"
printf 'log\tmethod\trun\tstatus\trelations\trelations_used\ttrans_mean\ttrans_std\trot_mean\trot_std\twall_s\tcpu_s\tduration_s\tscans\n' > "$RUNS"
printf 'log\tscans\tduration_s\tconvert_s\n' > "$CONVERSIONS"
FAILED=0
LOADAVG_START=$(cut -d' ' -f1-3 /proc/loadavg)
i=0
for log in "${LOGS[@]}"; do
  i=$((i + 1))
  name=$(basename "$log"); name=${name%.bz2}; name=${name%.gz}; name=${name%.clf}; name=${name%.log}
  relations="$(dirname "$log")/$name.relations"
  nrel=-
  if [ -f "$relations" ]; then nrel=$(grep -c '^[^#]' "$relations" || true); else relations=""; fi
  # Log duration: first to last laser stamp (Intel's lines are out of order, so min to max).
  read -r duration scans < <("$TOOLS/cat_log.sh" "$log" | awk '$1 == "FLASER" || $1 == "ROBOTLASER1" {
      s = $(NF - 2) + 0; if (n++ == 0 || s < lo) lo = s; if (n == 1 || s > hi) hi = s }
      END { printf "%.6f %d\n", hi - lo, n }')
  echo "== $name ($i of ${#LOGS[@]}): $scans scans, $duration s of log, ${relations:-no relations (not scored)}"
  converted="$TMP/$name"
  convert_s="-"
  if [ "$NEED_MRPT" -eq 1 ]; then
    echo "   converting for MRPT (carmen2rawlog with the four workarounds)"
    start=$(now)
    "$TOOLS/carmen_for_mrpt.sh" "$log" "$converted" || die "converting $log for MRPT failed"
    convert_s=$(elapsed "$start" "$(now)")
  fi
  printf '%s\t%s\t%s\t%s\n' "$name" "$scans" "$duration" "$convert_s" >> "$CONVERSIONS"
  for run in $(seq "$REPEAT"); do
    for method in "${METHOD_LIST[@]}"; do
      dir="$OUT/$name/$method/run$run"
      rm -rf "$dir"; mkdir -p "$dir"
      echo -n "   $method, run $run of $REPEAT: "
      status=ok
      case "$method" in
        waymark) times_=$(run_waymark "$log" "$dir") || status=failed ;;
        mrpt-icp-shipped) times_=$(run_icp shipped "$converted" "$dir") || status=failed ;;
        mrpt-icp-tuned) times_=$(run_icp tuned "$converted" "$dir") || status=failed ;;
      esac
      read -r wall cpu <<< "$times_"
      row=(- - - - -)
      poses=-
      if [ "$status" = ok ]; then
        poses=$(grep -vc '^#' "$dir/trajectory.txt" || true)
        if [ -n "$relations" ]; then
          "$W" --json eval relations "$dir/trajectory.txt" "$relations" > "$dir/relations.json" \
            2> "$dir/relations.err" || status=failed
        fi
      fi
      if [ "$status" = ok ] && [ -n "$relations" ]; then
        row=("$(value relations_used "$dir/relations.json")" "$(value trans_abs_mean "$dir/relations.json")"
             "$(value trans_abs_std "$dir/relations.json")" "$(value rot_abs_mean_deg "$dir/relations.json")"
             "$(value rot_abs_std_deg "$dir/relations.json")")
        printf '%.3f +- %.3f m, %.2f deg, ' "${row[1]}" "${row[2]}" "${row[3]}"
      fi
      if [ "$status" = ok ]; then
        echo "$wall s wall, $cpu s CPU, $poses poses"
      else
        FAILED=$((FAILED + 1)); wall=-; cpu=-
        echo "FAILED (see $dir)"
      fi
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$method" "$run" \
        "$status" "$nrel" "${row[@]}" "$wall" "$cpu" "$duration" "$poses" >> "$RUNS"
    done
  done
done

# --- table and JSON --------------------------------------------------------------------------
awk -f "$TOOLS/summarize.awk" "$RUNS" > "$OUT/summary.tsv"
awk -f "$TOOLS/table.awk" "$OUT/summary.tsv" > "$OUT/table.md"
{
  printf '{\n"build_dir": "%s",\n"mrpt": "%s",\n"repeat": %d,\n"cores": %d,\n' \
    "$(cd "$BUILD_DIR" && pwd)" "$(dpkg-query -W -f='${Version}' mrpt-apps 2> /dev/null || echo unknown)" \
    "$REPEAT" "$(nproc)"
  printf '"loadavg_start": "%s",\n"loadavg_end": "%s",\n' "$LOADAVG_START" "$(cut -d' ' -f1-3 /proc/loadavg)"
  printf '"summary": '; awk -f "$TOOLS/tsv_to_json.awk" "$OUT/summary.tsv"
  printf ',\n"conversions": '; awk -f "$TOOLS/tsv_to_json.awk" "$CONVERSIONS"
  printf ',\n"runs": '; awk -f "$TOOLS/tsv_to_json.awk" "$RUNS"
  printf '}\n'
} > "$OUT/results.json"
[ -z "$JSON" ] || cp "$OUT/results.json" "$JSON"
echo
cat "$OUT/table.md"
echo
echo "results in $OUT (table.md, results.json)${JSON:+ and $JSON}"
[ "$FAILED" -eq 0 ] || die "$FAILED run(s) failed"
