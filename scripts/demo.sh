#!/usr/bin/env bash
# The demo: synthesise a driving clip, validate it, reconstruct a Gaussian
# scene from its CONTEXT frames, render a lane-shift trajectory of the front
# camera (EXR + PNG), and evaluate the TARGET frames (report.json and contact
# sheets). Then the same through the service: pf-server and two pf-workers on
# loopback, the clip uploaded and reconstructed remotely, the lane shift
# rendered in chunks on both workers and downloaded, and the clip submitted
# again (a cache hit). Everything lands in $PF_DEMO_OUT (default demo-out/).
set -euo pipefail
BUILD_DIR=${1:-build}
PF="$BUILD_DIR/bin/pf"
OUT=${PF_DEMO_OUT:-demo-out}
rm -rf "$OUT"
mkdir -p "$OUT"

step() { printf '\n== %s\n' "$*"; }

step "pf synth --out $OUT/clip --seed 1"
"$PF" synth --out "$OUT/clip" --seed 1

step "pf validate $OUT/clip/clip.json"
"$PF" validate "$OUT/clip/clip.json"

step "pf reconstruct $OUT/clip/clip.json --out $OUT/scene.pfs"
"$PF" reconstruct "$OUT/clip/clip.json" --out "$OUT/scene.pfs"

step "pf scene info $OUT/scene.pfs"
"$PF" scene info "$OUT/scene.pfs"

# Views: the front camera at each CONTEXT time, shifted 0, 1, 2 and 3 m to its
# left, towards the centre line (a lane change the car never made; on the
# right an overtaking car is alongside).
python3 - "$OUT/clip/clip.json" "$OUT/lane_shift.json" <<'PY'
import json, sys
clip = json.load(open(sys.argv[1]))
front = [c for c in clip["cameras"] if c["id"] == "cam_front"] or clip["cameras"][:1]
cam = front[0]
frames = [f for f in clip["frames"] if f["camera"] == cam["id"]]
views = []
for f in frames[::5]:
    m = [float(v) for v in f["worldFromCamera"]]
    t = int(f.get("timestampUs", 0))
    for shift in (0, 1, 2, 3):
        shifted = list(m)
        for row in range(3):  # translate along the camera's -x axis (its left)
            shifted[4 * row + 3] -= shift * m[4 * row]
        views.append({"camera": cam["id"], "timestampUs": t, "worldFromCamera": shifted,
                      "name": f"left{shift}m_{t}"})
json.dump({"cameras": [cam], "views": views}, open(sys.argv[2], "w"), indent=1)
PY

step "pf render $OUT/scene.pfs --cameras $OUT/lane_shift.json --out $OUT/lane_shift"
"$PF" render "$OUT/scene.pfs" --cameras "$OUT/lane_shift.json" --out "$OUT/lane_shift"

# The TARGET frames, and every camera at 0.8 s moved 0-3 m to the left with
# its ray-cast truth (the extrapolation figures of docs/QUALITY.md).
step "pf eval $OUT/clip/clip.json --out $OUT/eval --lane-shift 1,2,3 --lane-shift-time-us 800000"
"$PF" eval "$OUT/clip/clip.json" --out "$OUT/eval" --lane-shift 1,2,3 --lane-shift-time-us 800000

# The service: a server on a free port with its store and blobs in $OUT/service,
# two workers, and the remote command line.
step "pf-server and two pf-worker on loopback"
SERVICE="$OUT/service"
mkdir -p "$SERVICE"
PIDS=()
cleanup() { [[ ${#PIDS[@]} -gt 0 ]] && kill -TERM "${PIDS[@]}" 2>/dev/null; wait 2>/dev/null || true; }
trap cleanup EXIT
"$BUILD_DIR/bin/pf-server" --listen 127.0.0.1:0 --port-file "$SERVICE/port" \
  --store "sqlite:$SERVICE/jobs.db" --blobs "$SERVICE/blobs" 2>"$SERVICE/server.log" &
PIDS+=($!)
for _ in $(seq 100); do [[ -s "$SERVICE/port" ]] && break; sleep 0.1; done
ADDR="127.0.0.1:$(cat "$SERVICE/port")"
for id in w1 w2; do
  "$BUILD_DIR/bin/pf-worker" --server "$ADDR" --id "$id" --work-dir "$SERVICE/$id" \
    2>"$SERVICE/$id.log" &
  PIDS+=($!)
done
echo "pf-server on $ADDR; logs in $SERVICE/"

step "pf --server $ADDR scene create $OUT/clip/clip.json --wait"
"$PF" --server "$ADDR" scene create "$OUT/clip/clip.json" --wait | tee "$SERVICE/create.txt"
SCENE=$(grep -o 'scenes/[0-9a-f]*' "$SERVICE/create.txt" | head -1)

step "pf --server $ADDR render $SCENE --cameras $OUT/lane_shift.json --out $OUT/remote --wait"
"$PF" --server "$ADDR" render "$SCENE" --cameras "$OUT/lane_shift.json" --out "$OUT/remote" \
  --chunk-frames 4 --wait

step "pf --server $ADDR scene create $OUT/clip/clip.json   (again: a cache hit)"
"$PF" --server "$ADDR" scene create "$OUT/clip/clip.json"

step "pf --server $ADDR jobs list"
"$PF" --server "$ADDR" jobs list
echo "chunks rendered per worker: w1 $(grep -c 'rendered chunk' "$SERVICE/w1.log" || true)," \
  "w2 $(grep -c 'rendered chunk' "$SERVICE/w2.log" || true)"
cleanup
PIDS=()

step "done"
echo "clip:        $OUT/clip/clip.json"
echo "scene:       $OUT/scene.pfs"
echo "lane shift:  $OUT/lane_shift/ (EXR + PNG per view, manifest.json)"
echo "eval:        $OUT/eval/report.json and contact sheets in $OUT/eval/"
echo "service:     $OUT/remote/ (the lane shift rendered by the workers), logs in $OUT/service/"
