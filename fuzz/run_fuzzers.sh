#!/usr/bin/env bash
# Runs each libFuzzer target of BUILD_DIR (configured with -DPF_FUZZ=ON) on
# its seeds for SECONDS, one after another, and prints one JSON line per
# target:
#   {"target": ..., "seconds": ..., "runs": ..., "execsPerSec": ...,
#    "coverage": <cov: of the last status line>, "crashes": ...}
# Exits 1 if any target crashed (crash, leak, timeout or out-of-memory); the
# reproducer is kept in BUILD_DIR/fuzz/artifacts/<target>-<time>/ and the
# log in BUILD_DIR/fuzz/logs/. Inputs that add coverage accumulate in
# BUILD_DIR/fuzz/corpus/<target>/ across runs.
#
# usage: fuzz/run_fuzzers.sh BUILD_DIR SECONDS [TARGET...]
#   Seeds come from PF_FUZZ_SEEDS (default BUILD_DIR/fuzz/seeds), written by
#   fuzz/make_seeds.sh when that directory does not exist yet (PF=... picks
#   the pf binary it uses). PF_FUZZ_TIMEOUT: seconds one input may take
#   before it counts as a hang (default 25). PF_FUZZ_MAX_LEN: the largest
#   input libFuzzer makes (default 65536; longer seeds, like the 2 MB Waymo
#   segment, are cut to it).
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: $0 BUILD_DIR SECONDS [TARGET...]" >&2
  exit 2
fi
BUILD_DIR=$(cd "$1" && pwd)
SECONDS_PER_TARGET=$2
shift 2
TARGETS=("$@")
if [[ ${#TARGETS[@]} -eq 0 ]]; then
  TARGETS=(clip_manifest_fuzzer tfrecord_fuzzer ply_fuzzer scene_file_fuzzer views_fuzzer
    task_result_fuzzer)
fi
HERE=$(cd "$(dirname "$0")" && pwd)
SEEDS=${PF_FUZZ_SEEDS:-$BUILD_DIR/fuzz/seeds}
if [[ ! -d $SEEDS ]]; then
  "$HERE/make_seeds.sh" "$BUILD_DIR" "$SEEDS"
fi

failed=0
for target in "${TARGETS[@]}"; do
  bin=$BUILD_DIR/fuzz/$target
  if [[ ! -x $bin ]]; then
    echo "run_fuzzers: $bin is missing (ninja -C $BUILD_DIR pf_fuzzers)" >&2
    exit 1
  fi
  stamp=$(date -u +%Y%m%dT%H%M%S)
  corpus=$BUILD_DIR/fuzz/corpus/$target
  artifacts=$BUILD_DIR/fuzz/artifacts/$target-$stamp
  log=$BUILD_DIR/fuzz/logs/$target-$stamp.log
  mkdir -p "$corpus" "$artifacts" "$(dirname "$log")"
  rc=0
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1} "$bin" -max_total_time="$SECONDS_PER_TARGET" -timeout="${PF_FUZZ_TIMEOUT:-25}" \
    -max_len="${PF_FUZZ_MAX_LEN:-65536}" -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$artifacts/" \
    "$corpus" "$SEEDS/$target" >"$log" 2>&1 || rc=$?

  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  execs=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  secs=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)
  crashes=$(find "$artifacts" -type f | wc -l)
  if [[ $rc -ne 0 && $crashes -eq 0 ]]; then crashes=1; fi  # Died without an artifact.
  [[ -z $(ls -A "$artifacts") ]] && rmdir "$artifacts"
  printf '{"target": "%s", "seconds": %s, "runs": %s, "execsPerSec": %s, "coverage": %s, "crashes": %s}\n' \
    "$target" "${secs:-$SECONDS_PER_TARGET}" "${runs:-0}" "${execs:-0}" "${cov:-0}" "$crashes"
  if [[ $crashes -ne 0 ]]; then
    failed=1
    echo "run_fuzzers: $target crashed (exit $rc); log $log, reproducer in $artifacts/:" >&2
    grep -m1 -A12 'ERROR: \|runtime error\|deadly signal' "$log" >&2 || tail -20 "$log" >&2
  fi
done
exit $failed
