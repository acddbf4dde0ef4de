#!/usr/bin/env bash
# make fuzz: builds waymark-fuzz alone on libFuzzer with clang 14, AddressSanitizer and
# UndefinedBehaviorSanitizer (UB aborts) in its own build directory, then runs every fuzz target
# (tests/fuzz/fuzz_targets.h) coverage-guided for a bounded time and prints, per target, the
# executions, libFuzzer's coverage (cov: edges, ft: features) and any crash. Issue 21.
#
#   FUZZ_DIR      build directory                      [build-fuzz]
#   FUZZ_SECONDS  seconds per target                   [30]
#   FUZZ_TARGETS  space-separated subset               [all: WAYMARK_FUZZ_TARGET=list]
#   FUZZ_JOBS     compile jobs                         [2]
#   FUZZ_CXX      the compiler, on the first build     [clang++-14]
#
# Each target's corpus grows in $FUZZ_DIR/fuzz/<target>/corpus (kept between runs, so a second
# run starts where the first stopped) from its code-made seeds and tests/fuzz/corpus/<target>/
# (read only). A crash leaves its input in $FUZZ_DIR/fuzz/<target>/crash-*; replay it with the
# project's build: build/tests/fuzz/waymark-fuzz --target <target> --replay FILE. Exits 1 when a
# target crashed.
set -euo pipefail
cd "$(dirname "$0")/.."

FUZZ_DIR=${FUZZ_DIR:-build-fuzz}
FUZZ_SECONDS=${FUZZ_SECONDS:-30}
FUZZ_JOBS=${FUZZ_JOBS:-2}
CXX_COMPILER=${FUZZ_CXX:-clang++-14}

# -O1 keeps the sanitizers' reports readable at a useful speed; Debug keeps assert() (Eigen's
# bounds checks among them) as one more oracle. fuzzer-no-link instruments the project's code for
# coverage; libFuzzer's own main is linked into waymark-fuzz alone (tests/fuzz/CMakeLists.txt).
SANITIZE="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fsanitize=fuzzer-no-link"
if [ ! -f "$FUZZ_DIR/build.ninja" ]; then
  cmake -S . -B "$FUZZ_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Debug \
    -DCMAKE_CXX_COMPILER="$CXX_COMPILER" \
    -DCMAKE_CXX_FLAGS="$SANITIZE -fno-omit-frame-pointer" -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
    -DWAYMARK_LIBFUZZER=ON
fi
cmake --build "$FUZZ_DIR" -j "$FUZZ_JOBS" --target waymark-fuzz
BUILT_AFTER=$SECONDS

BIN="$FUZZ_DIR/tests/fuzz/waymark-fuzz"
TARGETS=${FUZZ_TARGETS:-$(WAYMARK_FUZZ_TARGET=list "$BIN")}
# Leaks are checked once, when a target's run ends (LeakSanitizer at exit): libFuzzer's check
# after every input that allocated more than it freed runs LeakSanitizer after each input that
# starts a thread (feature extraction does), 15 times slower for image_decoding.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
export ASAN_SYMBOLIZER_PATH=${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer-14 || true)}

SUMMARY="$FUZZ_DIR/fuzz-summary.txt"
printf '%-18s %12s %8s %7s %7s %7s  %s\n' target executions exec/s cov ft corpus result \
  >"$SUMMARY"
failed=0
for target in $TARGETS; do
  work="$FUZZ_DIR/fuzz/$target"
  mkdir -p "$work/corpus"
  corpora=("$work/corpus")
  [ -d "tests/fuzz/corpus/$target" ] && corpora+=("tests/fuzz/corpus/$target")
  echo "== $target (${FUZZ_SECONDS} s)"
  status=0
  WAYMARK_FUZZ_TARGET="$target" WAYMARK_FUZZ_SEEDS="$work/corpus" \
    "$BIN" -max_total_time="$FUZZ_SECONDS" -timeout=10 -rss_limit_mb=2048 -detect_leaks=0 \
    -print_final_stats=1 -artifact_prefix="$work/" "${corpora[@]}" >"$work/log" 2>&1 || status=$?
  # The last status line: "#N  DONE  cov: C ft: F corp: K/S ... exec/s: E ..." (or before a crash).
  last=$(grep -E '^#[0-9]+.*cov: ' "$work/log" | tail -n 1 || true)
  field() { sed -nE "s|.*$1 ([0-9]+).*|\\1|p" <<<"$last"; }
  runs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+)/\1/p' "$work/log" | tail -n 1)
  result=ok
  if [ "$status" -ne 0 ]; then
    failed=1
    crash=$(ls -t "$work"/crash-* "$work"/leak-* "$work"/timeout-* "$work"/oom-* 2>/dev/null | head -n 1 || true)
    result="FAILED (exit $status) ${crash:-see $work/log}"
    grep -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error' "$work/log" | head -n 3 || true
  fi
  printf '%-18s %12s %8s %7s %7s %7s  %s\n' "$target" "${runs:-?}" "$(field 'exec/s:')" \
    "$(field 'cov:')" "$(field 'ft:')" "$(field 'corp:')" "$result" | tee -a "$SUMMARY"
done
echo "configure and build: ${BUILT_AFTER} s, fuzzing: $((SECONDS - BUILT_AFTER)) s" >>"$SUMMARY"
echo
cat "$SUMMARY"
exit "$failed"
