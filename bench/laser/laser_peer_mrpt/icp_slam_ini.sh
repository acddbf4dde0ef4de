#!/usr/bin/env bash
# Writes an icp-slam config: MRPT's shipped example with a settings preset applied.
#
#   icp_slam_ini.sh SHIPPED_INI PRESET LOG_DIR > run.ini
#   PRESET: shipped   the example unchanged (icpClassic, decimation 5, localise every 0.2 m / 5 deg)
#           tuned     the best of the 16-setting sweep on ACES + Intel in ../shared/peers/MRPT.md
#   LOG_DIR: where icp-slam writes log_estimated_path.txt (it empties this folder first)
# Both presets turn off what is not mapping: the 3-D window, the 3-D scene files, the per-step
# INFO lines; the example's rawlog_file is unused (the rawlog is icp-slam's second argument).
set -euo pipefail
SHIPPED=$1
PRESET=$2
LOG_DIR=$3
SETTINGS=(
  "MappingApplication.logOutput_dir=$LOG_DIR"
  "MappingApplication.LOG_FREQUENCY=0"
  "MappingApplication.SAVE_3D_SCENE=0"
  "MappingApplication.SAVE_POSE_LOG=0"
  "MappingApplication.SHOW_PROGRESS_3D_REAL_TIME=0"
  "MappingApplication.verbosity=LVL_WARN"
)
case "$PRESET" in
  shipped) ;;
  tuned) SETTINGS+=(
    "ICP.ICP_algorithm=icpLevenbergMarquardt"
    "ICP.corresponding_points_decimation=1"
    "MappingApplication.localizationLinDistance=0.1"
    "MappingApplication.localizationAngDistance=2") ;;
  *) echo "icp_slam_ini: unknown preset '$PRESET' (shipped, tuned)" >&2; exit 2 ;;
esac
# Replaces "key = value" lines of the named sections (the example's trailing // comments go with
# them) and appends the keys a section does not have at its end.
printf '%s\n' "${SETTINGS[@]}" | awk '
  NR == FNR { dot = index($0, "."); eq = index($0, "=")
              sec = substr($0, 1, dot - 1); key = substr($0, dot + 1, eq - dot - 1)
              value[sec, key] = substr($0, eq + 1); keys[sec] = keys[sec] " " key; next }
  function flush(   n, k, i) {
    n = split(keys[section], k, " ")
    for (i = 1; i <= n; i++) if (!((section, k[i]) in done)) print k[i] " = " value[section, k[i]]
  }
  /^[ \t]*\[/ { flush(); section = $0; gsub(/[][ \t]/, "", section) }
  /=/ { key = $0; sub(/[ \t]*=.*/, "", key); sub(/^[ \t]+/, "", key)
        if ((section, key) in value) { print key " = " value[section, key]; done[section, key] = 1; next } }
  { print }
  END { flush() }' - "$SHIPPED"
