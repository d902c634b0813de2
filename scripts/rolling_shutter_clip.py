#!/usr/bin/python3
"""A rolling-shutter copy of a synth clip: every frame read line by line while the rig moves.

    /usr/bin/python3 scripts/rolling_shutter_clip.py --clip /tmp/s1 --out DIR \
        [--readout-us 30000] [--pf build/bin/pf]

Every frame of every camera becomes a rolling-shutter frame: read top to bottom over
--readout-us from the frame's pose and time, while the camera moves on towards its next
frame (the same share of the way as the readout is of the frame interval; the last frame
of a camera continues the step from the one before; rotation held). `pf synth render`
ray-casts each frame line by line, each line from its pose and at its time, with its
depth; the frames keep their roles. Writes two manifests that share those images:

    DIR/clip.json                 every frame with its `rollingShutter`
    DIR/clip_global_context.json  the CONTEXT frames without it (taken as global shutter,
                                  reconstruction lifts each image from one pose); the
                                  TARGET frames keep it, so `pf eval` measures both
                                  reconstructions against the same line-by-line truth

The LiDAR sweeps and synth.json are copied from the source clip.
"""

import argparse
import copy
import json
import os
import shutil
import subprocess
import sys


def rolling_shutters(clip, readout_us):
    """frame index -> its rollingShutter object."""
    by_camera = {}
    for i, frame in enumerate(clip["frames"]):
        by_camera.setdefault(frame["camera"], []).append(i)
    out = {}
    for indices in by_camera.values():
        indices.sort(key=lambda i: int(clip["frames"][i]["timestampUs"]))
        if len(indices) < 2:
            sys.exit("rolling_shutter_clip: every camera needs two frames to move between")
        for k, i in enumerate(indices):
            a = clip["frames"][i]
            # The step to the next frame (from the one before, for the last).
            p, q = (indices[k], indices[k + 1]) if k + 1 < len(indices) else (indices[k - 1], i)
            fp, fq = clip["frames"][p], clip["frames"][q]
            share = readout_us / (int(fq["timestampUs"]) - int(fp["timestampUs"]))
            end = list(a["worldFromCamera"])
            for j in (3, 7, 11):
                end[j] = a["worldFromCamera"][j] + share * (
                    fq["worldFromCamera"][j] - fp["worldFromCamera"][j])
            out[i] = {"readout": "TOP_TO_BOTTOM", "readoutUs": str(readout_us),
                      "worldFromCameraEnd": end}
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--clip", required=True, help="directory of a pf synth clip")
    parser.add_argument("--out", required=True, help="directory for the rolling-shutter clip")
    parser.add_argument("--readout-us", type=int, default=30000)
    parser.add_argument("--pf", default=os.path.join(os.path.dirname(__file__), "../build/bin/pf"))
    args = parser.parse_args()

    with open(os.path.join(args.clip, "clip.json")) as f:
        clip = json.load(f)
    shutters = rolling_shutters(clip, args.readout_us)
    os.makedirs(args.out, exist_ok=True)
    views = []
    for i, frame in enumerate(clip["frames"]):
        views.append({"camera": frame["camera"], "timestampUs": frame["timestampUs"],
                      "worldFromCamera": frame["worldFromCamera"], "name": f"frame_{i}",
                      "rollingShutter": shutters[i]})
    views_path = os.path.join(args.out, "views.json")
    with open(views_path, "w") as f:
        json.dump({"views": views}, f)
    command = [args.pf, "synth", "render", "--clip", args.clip, "--cameras", views_path,
               "--out", os.path.join(args.out, "frames")]
    run = subprocess.run(command, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"rolling_shutter_clip: {' '.join(command)}: {run.stderr.strip()}")
    for name in ("lidar", "synth.json"):
        source, copy_to = os.path.join(args.clip, name), os.path.join(args.out, name)
        if os.path.isdir(source):
            shutil.copytree(source, copy_to, dirs_exist_ok=True)
        elif os.path.exists(source):
            shutil.copyfile(source, copy_to)

    rolling = copy.deepcopy(clip)
    for i, frame in enumerate(rolling["frames"]):
        frame["image"] = f"frames/frame_{i}.png"
        if "depth" in frame:
            frame["depth"] = f"frames/frame_{i}.exr"
        frame["rollingShutter"] = shutters[i]
    global_context = copy.deepcopy(rolling)
    for frame in global_context["frames"]:
        if frame.get("role", "CONTEXT") != "TARGET":
            del frame["rollingShutter"]
    for name, manifest in (("clip.json", rolling), ("clip_global_context.json", global_context)):
        with open(os.path.join(args.out, name), "w") as f:
            json.dump(manifest, f, indent=1)
    print(json.dumps({"frames": len(views), "readoutUs": args.readout_us,
                      "clip": os.path.join(args.out, "clip.json"),
                      "globalContext": os.path.join(args.out, "clip_global_context.json")}))


if __name__ == "__main__":
    main()
