#!/usr/bin/env bash
# The demo: synthesise a driving clip and validate it. Later issues extend it
# to reconstruction and rendering.
set -euo pipefail
BUILD_DIR=${1:-build}
PF="$BUILD_DIR/bin/pf"
OUT=${PF_DEMO_OUT:-demo-out}
rm -rf "$OUT"
echo "== pf synth --out $OUT/clip"
"$PF" synth --out "$OUT/clip" --seed 1
echo "== pf validate $OUT/clip/clip.json"
"$PF" validate "$OUT/clip/clip.json"
