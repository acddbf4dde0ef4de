#!/usr/bin/env bash
# Converts a CARMEN log into an MRPT rawlog that MRPT 2.5's icp-slam reads correctly, and lists
# the laser stamps in rawlog order (so icp-slam's per-step path can be stamped again).
#
#   carmen_for_mrpt.sh LOG DIR    LOG: plain, .gz or .bz2; writes DIR/mrpt.clf, DIR/mrpt.rawlog,
#                                 DIR/stamps.txt (one laser stamp per line, text as in the log)
#
# carmen2rawlog 2.5.8 needs four workarounds (../shared/peers/MRPT.md):
#  1. it turns a stamp ts into 1e-6*ts microseconds, so every stamp of a log becomes the same and
#     ICP gets no motion between scans: writing the stamp as "<ts>e12" cancels the factor;
#  2. a FLASER line carries no beam geometry and the default resolution (0.5 deg) gives a
#     180-beam scan a 90 deg field of view: PARAM laser_front_laser_resolution 1.0 (0.5 for 360);
#  3. readings >= PARAM robot_front_laser_max are invalid: set it to the log's largest reading,
#     its no-return marker (ACES 50.00, Intel 81.83), so no-returns are not mapped as walls;
#  4. Intel has out-of-order laser lines: sort them by stamp (stable).
# ODOM lines are dropped: carmen2rawlog ignores them (it takes odometry from the laser lines,
# one CObservationOdometry then one CObservation2DRangeScan per line). RLASER lines are dropped
# too: Waymark's replay uses FLASER and ROBOTLASER1 only, and both sides must see the same scans.
set -euo pipefail
LOG=$1
DIR=$2
mkdir -p "$DIR"
: > "$DIR/params.txt"  # a ROBOTLASER1 log may have no PARAM line (its lines carry their geometry)
# The log's PARAM lines then the geometry ones (2, 3) into params.txt; each laser line prefixed by
# its stamp (third field from the end) into lasers.tsv for the sort (4).
"$(dirname "$0")/cat_log.sh" "$LOG" | awk -v params="$DIR/params.txt" -v lasers="$DIR/lasers.tsv" '
  $1 == "PARAM" { print > params; next }
  $1 == "FLASER" || $1 == "ROBOTLASER1" {
    if ($1 == "FLASER") {
      n = $2
      if (beams == "") beams = n
      else if (n != beams) { printf "FLASER lines with %d and %d beams\n", beams, n > "/dev/stderr"; exit 2 }
      for (i = 3; i < 3 + n; i++) if (max == "" || $i + 0 > max + 0) max = $i
    }
    print $(NF - 2) "\t" $0 > lasers
  }
  END {
    if (beams == "") exit 0
    if (beams <= 181) res = "1.0"
    else if (beams == 360 || beams == 361) res = "0.5"
    else { printf "FLASER lines with %d beams: no known field of view\n", beams > "/dev/stderr"; exit 2 }
    # Later PARAM lines win in carmen2rawlog, so these come after the log'"'"'s own.
    print "PARAM laser_front_laser_resolution " res " nohost 0" > params
    print "PARAM robot_front_laser_max " max " nohost 0" > params
  }'
[ -s "$DIR/lasers.tsv" ] || { echo "carmen_for_mrpt: no FLASER or ROBOTLASER1 line in $LOG" >&2; exit 2; }
sort -s -g -k1,1 "$DIR/lasers.tsv" > "$DIR/sorted.tsv"
cut -f1 "$DIR/sorted.tsv" > "$DIR/stamps.txt"
{
  cat "$DIR/params.txt"
  cut -f2- "$DIR/sorted.tsv" | awk '{ $(NF - 2) = $(NF - 2) "e12"; print }'  # (1)
} > "$DIR/mrpt.clf"
rm -f "$DIR/lasers.tsv" "$DIR/sorted.tsv" "$DIR/params.txt"
carmen2rawlog -q -w -i "$DIR/mrpt.clf" -o "$DIR/mrpt.rawlog" > "$DIR/carmen2rawlog.log" 2>&1 \
  || { cat "$DIR/carmen2rawlog.log" >&2; exit 1; }
