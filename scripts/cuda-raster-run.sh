#!/usr/bin/env bash
# On a GPU machine: the CUDA rasterizer's checks and benchmarks in one run,
# from what scripts/cuda-raster-pack.sh packed. Writes the log, the tests'
# XML and one JSON line per benchmark (bench.jsonl) to OUT_DIR.
#  1. cuda_rasterizer_test: every output, camera model, SH, wide features,
#     colour gradients and edits against the CPU rasterizer; and
#     cuda_colour_fit_test: the colour fit's GPU solve against the CPU's.
#  2. compute-sanitizer (memcheck) over two of those tests, when installed.
#  3. pf_raster_bench on the GPU: 100K Gaussians at 768x576 and 1M at
#     1920x1080 (3 and 32 channels), each compared with the CPU's render
#     (--compare-cpu); and the CPU rasterizer on the same machine beside it.
#  4. Nsight Compute's per-kernel summary of one 1M-Gaussian 1080p render.
#
#   scripts/cuda-raster-run.sh [PACK_DIR] [OUT_DIR]   (defaults: .cuda-raster /tmp/cuda-raster)
#   NCU=0: without step 4.
set -uo pipefail
PACK=$(realpath "${1:-.cuda-raster}")
OUT_DIR=${2:-/tmp/cuda-raster}
mkdir -p "$OUT_DIR"
exec > >(tee "$OUT_DIR/log.txt") 2>&1
export LD_LIBRARY_PATH=$PACK/so${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
date -u
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>&1 || true
nproc
start=$(date +%s)
rc=0
"$PACK/cuda_rasterizer_test" --gtest_output="xml:$OUT_DIR/cuda_rasterizer_test.xml" || rc=1
"$PACK/cuda_colour_fit_test" --gtest_output="xml:$OUT_DIR/cuda_colour_fit_test.xml" || rc=1
echo "tests: exit status $rc ($(($(date +%s) - start)) s)"
# memcheck NAME PROGRAM FILTER: compute-sanitizer over the tests FILTER names.
memcheck() {
  timeout 240 compute-sanitizer --tool memcheck --error-exitcode 3 "$PACK/$2" \
    --gtest_filter="$3" >"$OUT_DIR/$1.txt" 2>&1
  local status=$?
  tail -3 "$OUT_DIR/$1.txt"
  echo "$1: exit status $status ($(($(date +%s) - start)) s)"
  [ "$status" = 0 ] || rc=1
}
if command -v compute-sanitizer >/dev/null; then
  memcheck memcheck cuda_rasterizer_test '*EveryCameraModel*:*OneUpload*'
  memcheck memcheck_colour_fit cuda_colour_fit_test '*SolveNeedsAStart*:*MatchesTheCpuSolve*'
fi
bench() { "$PACK/pf_raster_bench" "$@" | tee -a "$OUT_DIR/bench.jsonl" || rc=1; }
bench --device cuda:0 --gaussians 100000 --width 768 --height 576 --repeat 50 --compare-cpu
bench --device cuda:0 --gaussians 1000000 --width 1920 --height 1080 --repeat 30 --compare-cpu
bench --device cuda:0 --gaussians 1000000 --width 1920 --height 1080 --channels 32 --repeat 20
bench --device cpu --gaussians 100000 --width 768 --height 576 --repeat 10
bench --device cpu --gaussians 1000000 --width 1920 --height 1080 --repeat 3
# Where one 1M-Gaussian 1080p render's GPU time goes, kernel by kernel.
if [ "${NCU:-1}" = 1 ] && command -v ncu >/dev/null; then
  timeout 150 ncu --section SpeedOfLight --print-summary per-kernel "$PACK/pf_raster_bench" \
    --device cuda:0 --gaussians 1000000 --width 1920 --height 1080 --repeat 1 \
    >"$OUT_DIR/ncu.txt" 2>&1
  echo "ncu: exit status $? ($(($(date +%s) - start)) s)"
  grep -E "Kernel|Duration|^  [A-Za-z_].*\(" "$OUT_DIR/ncu.txt" | head -60
fi
echo "done in $(($(date +%s) - start)) s, exit status $rc"
exit $rc
