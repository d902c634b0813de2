#!/usr/bin/env bash
# Every GPU check and benchmark in one run on a lent GPU machine, within 10
# minutes: the CUDA rasterizer's (scripts/cuda-raster-run.sh: its tests
# against the CPU rasterizer, memcheck, the raster benchmarks) and fusion's
# (scripts/cuda-fusion-run.sh: the tensor-fusion tests, the fusion benchmark,
# the whole reconstruction of the default synth clip on cpu and cuda:0).
# Pack both here first:
#
#   scripts/cuda-raster-pack.sh build .cuda-raster
#   scripts/cuda-fusion-pack.sh build .cuda-pack
#   scripts/cuda-checks.sh [OUT_DIR]            (on the GPU machine; default /tmp/cuda-checks)
#
# Writes raster/ and fusion/ under OUT_DIR; exits non-zero when either failed.
set -uo pipefail
OUT_DIR=${1:-/tmp/cuda-checks}
cd "$(dirname "$0")/.."
rc=0
scripts/cuda-raster-run.sh .cuda-raster "$OUT_DIR/raster" || rc=1
if [ -d .cuda-pack ]; then
  RUNS=${RUNS:-2} scripts/cuda-fusion-run.sh .cuda-pack "$OUT_DIR/fusion" || rc=1
else
  echo "no .cuda-pack: fusion's checks not run (scripts/cuda-fusion-pack.sh packs them)"
  rc=1
fi
echo "GPU checks: exit status $rc"
exit $rc
