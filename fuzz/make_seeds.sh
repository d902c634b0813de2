#!/usr/bin/env bash
# Writes the fuzzers' seed corpora from real samples into OUT_DIR/<target>/:
#   clip_manifest_fuzzer  clip.json of a small `pf synth` clip and of the DGP
#                         sample imported with `pf import dgp`; a manifest
#                         nested 30000 deep and one of 1000 frames
#   tfrecord_fuzzer       the Waymo sample segment, and small re-framed files
#                         (valid CRCs) holding slices of its first record
#   ply_fuzzer            `pf scene export` of a reconstructed scene, and two
#                         hand-written ASCII PLYs (f_dc and red/green/blue)
#   scene_file_fuzzer     `pf reconstruct` of the synth clip (small N_s, N_d)
#   views_fuzzer          hand-written RenderViews (every feature) and the
#                         demo's lane-shift views of the synth clip; views
#                         nested 30000 deep
#   task_result_fuzzer    CompleteTaskRequests of a render chunk (views v00,
#                         v01) and of a reconstruction, one whose
#                         manifest_views_json is nested 30000 deep
# Nothing is copied into the repository. The samples under PF_DATA_DIR
# (default: ../shared/data beside the repository) are skipped when absent.
#
# usage: fuzz/make_seeds.sh BUILD_DIR OUT_DIR
#   PF=path/to/pf overrides BUILD_DIR/bin/pf (e.g. a non-sanitized build's).
set -euo pipefail
if [[ $# -ne 2 ]]; then
  echo "usage: $0 BUILD_DIR OUT_DIR" >&2
  exit 2
fi
BUILD_DIR=$1
OUT=$2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
PF=${PF:-$BUILD_DIR/bin/pf}
DATA=${PF_DATA_DIR:-$ROOT/../shared/data}
if [[ ! -x $PF ]]; then
  echo "make_seeds: no pf binary at $PF (build target pf, or set PF=...)" >&2
  exit 1
fi

# pf may be the sanitizer tree's own (make fuzz-smoke): its leak report at
# exit (a third-party one, see lsan_suppressions.txt) must not fail the seeds.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}

WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
mkdir -p "$OUT"/{clip_manifest_fuzzer,tfrecord_fuzzer,ply_fuzzer,scene_file_fuzzer,views_fuzzer}
mkdir -p "$OUT"/task_result_fuzzer
log() { echo "make_seeds: $*" >&2; }

# A small synth clip, a scene reconstructed from it, and its PLY export.
"$PF" synth --out "$WORK/synth" --seed 1 --width 64 --height 48 --frames 2 >/dev/null 2>&1
cp "$WORK/synth/clip.json" "$OUT/clip_manifest_fuzzer/synth_clip.json"
"$PF" reconstruct "$WORK/synth/clip.json" --out "$WORK/scene.pfscene" --ns 4 --nd 4 >/dev/null 2>&1
cp "$WORK/scene.pfscene" "$OUT/scene_file_fuzzer/synth.pfscene"
"$PF" scene export "$WORK/scene.pfscene" --ply "$OUT/ply_fuzzer/synth.ply" >/dev/null 2>&1

# The DGP sample as a clip.
if [[ -d $DATA/dgp_test_scene/scene_02 ]]; then
  "$PF" import dgp "$DATA/dgp_test_scene/scene_02" --out "$WORK/dgp" >/dev/null 2>&1
  cp "$WORK/dgp/clip.json" "$OUT/clip_manifest_fuzzer/dgp_clip.json"
else
  log "skipping the DGP clip: $DATA/dgp_test_scene/scene_02 is absent"
fi

# The Waymo segment as it is, and small files framing slices of its first
# record (the whole segment is one 2 MB record, more than libFuzzer's default
# input size).
WAYMO=$DATA/waymo_one_frame/pvps_data_one_frame.tfrecord
if [[ -f $WAYMO ]]; then
  install -m 0644 "$WAYMO" "$OUT/tfrecord_fuzzer/waymo_segment.tfrecord"
  SOURCE=$WAYMO
else
  log "skipping the Waymo segment: $WAYMO is absent"
  SOURCE=$WORK/synth/clip.json
fi
/usr/bin/python3 - "$SOURCE" "$OUT/tfrecord_fuzzer" <<'PY'
import struct, sys

def crc32c(data):
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF

def masked(data):
    crc = crc32c(data)
    return ((((crc >> 15) | (crc << 17)) & 0xFFFFFFFF) + 0xA282EAD8) & 0xFFFFFFFF

def frame(payload):
    length = struct.pack("<Q", len(payload))
    return length + struct.pack("<I", masked(length)) + payload + struct.pack("<I", masked(payload))

source, out = sys.argv[1], sys.argv[2]
data = open(source, "rb").read()
payload = data[12:12 + 4096] if source.endswith(".tfrecord") else data[:4096]
open(f"{out}/one_record.tfrecord", "wb").write(frame(payload[:512]))
open(f"{out}/three_records.tfrecord", "wb").write(
    frame(payload[:64]) + frame(b"") + frame(payload[64:1024]))
PY

# Hand-written ASCII PLYs: the 3DGS layout with SH degree 1, and plain
# red/green/blue colours with an extra element carrying a list property.
cat > "$OUT/ply_fuzzer/ascii_sh1.ply" <<'PLY'
ply
format ascii 1.0
comment pointforward time_origin_us=100 sh_degree=1
element vertex 2
property float x
property float y
property float z
property float f_dc_0
property float f_dc_1
property float f_dc_2
property float f_rest_0
property float f_rest_1
property float f_rest_2
property float f_rest_3
property float f_rest_4
property float f_rest_5
property float f_rest_6
property float f_rest_7
property float f_rest_8
property float opacity
property float scale_0
property float scale_1
property float scale_2
property float rot_0
property float rot_1
property float rot_2
property float rot_3
property float pf_time
property float pf_lifespan
end_header
0 0 1 0.1 0.2 0.3 0 0 0 0 0 0 0 0 0 1.5 -2 -2 -2 1 0 0 0 0 inf
1 2 3 -0.1 0 0.5 0.1 0.1 0.1 0.2 0.2 0.2 0.3 0.3 0.3 -1 -1 -3 -2 0.5 0.5 0.5 0.5 0.25 2
PLY
cat > "$OUT/ply_fuzzer/ascii_rgb.ply" <<'PLY'
ply
format ascii 1.0
element vertex 2
property double x
property double y
property double z
property uchar red
property uchar green
property uchar blue
property float opacity
property float scale_0
property float scale_1
property float scale_2
property float rot_0
property float rot_1
property float rot_2
property float rot_3
element face 1
property list uchar int vertex_indices
end_header
0 0 1 255 0 128 2 -1 -1 -1 1 0 0 0
0 1 0 10 20 30 -2 -2 -2 -2 0 1 0 0
3 0 1 0
PLY

# RenderViews: every feature by hand, and the demo's lane-shift views.
cat > "$OUT/views_fuzzer/all_features.json" <<'JSON'
{
  "cameras": [
    {"id": "front", "width": 64, "height": 48, "intrinsics": {"fx": 50, "fy": 51, "cx": 32, "cy": 24}},
    {"id": "side", "width": 32, "height": 32, "intrinsics": {"fx": 20, "fy": 20, "cx": 16, "cy": 16},
     "distortion": {"model": "OPENCV", "k1": -0.1, "k2": 0.01, "p1": 0.001, "p2": -0.002, "k3": 0.0001}},
    {"id": "fish", "width": 32, "height": 32, "intrinsics": {"fx": 20, "fy": 20, "cx": 16, "cy": 16},
     "distortion": {"model": "FISHEYE", "k1": 0.01, "k2": 0.001, "k3": 0, "k4": 0}}
  ],
  "views": [
    {"camera": "front", "timestampUs": "1700000000000001", "worldFromCamera": [0,0,1,5, -1,0,0,2, 0,-1,0,1.5, 0,0,0,1]},
    {"camera": "side", "timestampUs": 42, "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "name": "side_view"},
    {"camera": "fish", "timestampUs": 7, "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}
  ],
  "edits": [
    {"instance": "ped2", "kind": "REMOVE"},
    {"instance": "car1", "kind": "TRAJECTORY", "boxes": [
      {"timestampUs": 200, "center": [2, 0, 0], "rotation": [2, 0, 0, 0]},
      {"timestampUs": 100, "center": [1, 0, 0], "rotation": [1, 0, 0, 0], "size": [4, 2, 1.5]}
    ]}
  ]
}
JSON
/usr/bin/python3 - "$WORK/synth/clip.json" "$OUT/views_fuzzer/lane_shift.json" <<'PY'
import json, sys
clip = json.load(open(sys.argv[1]))
cam = clip["cameras"][0]
views = []
for f in [f for f in clip["frames"] if f["camera"] == cam["id"]]:
    m = [float(v) for v in f["worldFromCamera"]]
    t = int(f.get("timestampUs", 0))
    for shift in (0, 2):
        shifted = list(m)
        for row in range(3):
            shifted[4 * row + 3] -= shift * m[4 * row]
        views.append({"camera": cam["id"], "timestampUs": t, "worldFromCamera": shifted,
                      "name": f"left{shift}m_{t}"})
json.dump({"cameras": [cam], "views": views}, open(sys.argv[2], "w"), indent=1)
PY

# What the review of hostile input sent (docs/RELIABILITY.md, "Hostile
# input"): nesting far past the parsers' depth limit, many frames, and a
# worker's result for a chunk, good and poisoned. Each fits -max_len.
/usr/bin/python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
deep = 30000
open(f"{out}/clip_manifest_fuzzer/deep_nesting.json", "w").write(
    '{"name": ' + "[" * deep + "]" * deep + "}")
frames = [{"camera": "c", "timestampUs": i, "image": f"i/{i}.png"} for i in range(1000)]
open(f"{out}/clip_manifest_fuzzer/many_frames.json", "w").write(
    json.dumps({"cameras": [{"id": "c", "width": 8, "height": 8}], "frames": frames},
               separators=(",", ":")))
open(f"{out}/views_fuzzer/deep_nesting.json", "w").write(
    '{"cameras": [{"id": ' + "[" * deep + "]" * deep + "}]}")
sha = "ab" * 32
def render(views_json):
    files = [{"name": f"{v}{ext}", "view": v, "digest": {"sha256": sha, "sizeBytes": "10"}}
             for v in ("v00", "v01") for ext in (".exr", ".png")]
    return {"workerId": "w1", "taskId": "t", "attempt": 1,
            "render": {"files": files, "manifestViewsJson": views_json}}
entries = json.dumps([{"name": v, "exr": f"{v}.exr", "png": f"{v}.png", "width": 8, "height": 8}
                      for v in ("v00", "v01")])
open(f"{out}/task_result_fuzzer/render_chunk.json", "w").write(json.dumps(render(entries)))
open(f"{out}/task_result_fuzzer/deep_manifest_views.json", "w").write(
    json.dumps(render("[" * deep + "]" * deep)))
open(f"{out}/task_result_fuzzer/reconstruct.json", "w").write(json.dumps(
    {"workerId": "w1", "taskId": "t", "attempt": 1, "reconstruct": {"scene": {
        "gaussians": "10", "staticGaussians": "8", "dynamicGaussians": "2",
        "instances": ["car1"], "boundsMin": [-1, -1, -1], "boundsMax": [1, 1, 1],
        "sceneFile": {"sha256": sha, "sizeBytes": "100"}}}}))
open(f"{out}/task_result_fuzzer/manifest_views.json", "w").write(entries)
PY

for dir in "$OUT"/*/; do
  log "$(basename "$dir"): $(ls "$dir" | wc -l) seeds"
done
