#!/usr/bin/env bash
# Runs the benchmarks and evaluations; results go to out/bench (JSON + markdown tables).
# Needs ../shared beside the repository for the real-data parts.
set -euo pipefail
BUILD_DIR=${1:-build}
SHARED=${SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared}
OUT=${OUT:-out/bench}
mkdir -p "$OUT"
echo "== micro-benchmarks (engine hot paths)"
"$BUILD_DIR/bin/waymark-micro-bench" --benchmark_repetitions=3 --benchmark_report_aggregates_only=true \
  --benchmark_out="$OUT/micro_bench.json" --benchmark_out_format=json
echo "== active-exploration planner: ms per decision vs candidate controls and segments"
"$BUILD_DIR/bin/waymark-planner-bench" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
  --benchmark_out="$OUT/planner_bench.json" --benchmark_out_format=json
echo "== RecognizeCrossing latency, memory and clustering vs database size"
"$BUILD_DIR/bin/waymark-bench-recognition" --shared "$SHARED" --out "$OUT" ${BENCH_SIZES:+--sizes $BENCH_SIZES}
echo "== enrollment cost: SIFT and the incremental clustering vs the quadratic reference"
"$BUILD_DIR/bin/waymark-bench-enroll" --shared "$SHARED" ${BENCH_SIZES:+--sizes $BENCH_SIZES} \
  --reference-max 360 | tee "$OUT/bench_enroll.md"
if [ -x "$BUILD_DIR/bin/waymark-vpr-eval" ]; then
  echo "== recognition accuracy on the place-recognition sets"
  "$BUILD_DIR/bin/waymark-vpr-eval" --shared "$SHARED" --out "$OUT"
fi
if [ -x "$BUILD_DIR/bin/waymark-rotation-eval" ]; then
  echo "== rotation robustness"
  "$BUILD_DIR/bin/waymark-rotation-eval" --out "$OUT"
fi
if [ -x "$BUILD_DIR/bin/waymark-laser-eval" ]; then
  echo "== laser SLAM engine (in-process): time, memory, relations metric"
  LASER="$SHARED/data/laser"
  for log in aces intel; do
    "$BUILD_DIR/bin/waymark-laser-eval" --log "$LASER/$log/$log.clf.bz2" \
      --relations "$LASER/$log/$log.relations" --out "$OUT/laser_$log" --json > "$OUT/laser_$log.json"
  done
  # Update cost vs segments in the filter (the per-bin timings; see bench/laser/laser_slam_eval.cc).
  "$BUILD_DIR/bin/waymark-laser-eval" --log "$LASER/aces/aces.clf.bz2" --max-active-segments 400 \
    --active-radius 1000 --freeze-after-scans 1000000 --json > "$OUT/laser_aces_active400.json"
fi
if command -v icp-slam > /dev/null; then
  echo "== laser SLAM beside MRPT icp-slam (ACES, Intel; through the server; relations metric)"
  "$(dirname "$0")/laser/laser_peer_mrpt.sh" "$BUILD_DIR" --out "$OUT/laser_peer_mrpt"
else
  echo "== laser SLAM beside MRPT icp-slam: skipped (no icp-slam: apt-get install mrpt-apps mrpt-common)"
fi
echo "== exploration modes in the simulator (world x mode x seed; bench/laser/explore_eval.sh)"
OUT="$OUT/explore" "$(dirname "$0")/laser/explore_eval.sh" "$BUILD_DIR"
echo "== robot loop: stop and resume latency when the server is killed under a driving robot"
"$BUILD_DIR/bin/waymark-robot-bench" --trials 20 --json > "$OUT/robot_safety.json"
echo "== visual odometry: ATE/RPE and ms per stage, plain vs boxes vs full method (5 seeds)"
VSLAM="$SHARED/data/vslam"
"$BUILD_DIR/bin/waymark-vo-bench" "$VSLAM/bonn_rgbd_crowd_frames270-409" --camera bonn \
  --models "$SHARED/models/yolo-fastest-1.1-coco" --configs none,boxes:yolo,full:yolo,full:hog \
  --seeds 5 | tee "$OUT/vo_bonn.txt"
"$BUILD_DIR/bin/waymark-vo-bench" "$VSLAM/kitti_odom06_frames000-050" \
  --models "$SHARED/models/yolo-fastest-1.1-coco" --configs none,boxes:yolo,full:yolo \
  --seeds 5 | tee "$OUT/vo_kitti.txt"
echo "== visual odometry detectors: ms per frame"
"$BUILD_DIR/bin/waymark-vo-detector-bench" --shared "$SHARED" | tee "$OUT/vo_detectors.txt"
echo "results in $OUT"
