#!/usr/bin/python3
"""Rolling-shutter renders of a synth clip's scene against the ray caster's truth.

    /usr/bin/python3 scripts/rolling_shutter_eval.py --clip /tmp/s1 --scene S.pfscene \
        --out DIR [--camera cam_front] [--readout-us 30000] [--pf build/bin/pf]

For every TARGET frame of the camera (but the last of its frames), a view at the
frame's pose and time, read top to bottom over --readout-us while the camera moves on
towards its next frame (the same share of the way as the readout is of the frame
interval; rotation held). The views are written twice, with and without their
`rollingShutter`; `pf synth render` ray-casts both (line by line for the rolling one) and
`pf render` renders both from SCENE. Prints one JSON line: the mean PSNR of the PNGs of
each render against each truth.
"""

import argparse
import glob
import json
import math
import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio


def views_of(clip, camera, readout_us):
    frames = sorted((f for f in clip["frames"] if f["camera"] == camera),
                    key=lambda f: int(f["timestampUs"]))
    rolling, plain = [], []
    for a, b in zip(frames, frames[1:]):
        if a.get("role") != "TARGET":
            continue
        ta, tb = int(a["timestampUs"]), int(b["timestampUs"])
        share = readout_us / (tb - ta)
        end = list(a["worldFromCamera"])
        for i in (3, 7, 11):
            end[i] = a["worldFromCamera"][i] + share * (b["worldFromCamera"][i] - end[i])
        view = {"camera": camera, "timestampUs": str(ta),
                "worldFromCamera": a["worldFromCamera"], "name": f"{camera}_{ta}"}
        plain.append(dict(view))
        view["rollingShutter"] = {"readout": "TOP_TO_BOTTOM", "readoutUs": str(readout_us),
                                  "worldFromCameraEnd": end}
        rolling.append(view)
    return rolling, plain


def mean_psnr(ours_dir, truth_dir):
    values = []
    for truth in sorted(glob.glob(os.path.join(truth_dir, "*.png"))):
        a = oiio.ImageBuf(os.path.join(ours_dir, os.path.basename(truth))).get_pixels(oiio.FLOAT)
        b = oiio.ImageBuf(truth).get_pixels(oiio.FLOAT)
        mse = float(np.mean((a[:, :, :3] - b[:, :, :3]) ** 2))
        values.append(10 * math.log10(1 / mse))
    return round(sum(values) / len(values), 2) if values else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--clip", required=True, help="directory of a pf synth clip")
    parser.add_argument("--scene", required=True, help="its reconstruction (pf reconstruct)")
    parser.add_argument("--out", required=True, help="directory for views, truths and renders")
    parser.add_argument("--camera", default="cam_front")
    parser.add_argument("--readout-us", type=int, default=30000)
    parser.add_argument("--pf", default=os.path.join(os.path.dirname(__file__), "../build/bin/pf"))
    args = parser.parse_args()

    with open(os.path.join(args.clip, "clip.json")) as f:
        clip = json.load(f)
    rolling, plain = views_of(clip, args.camera, args.readout_us)
    if not rolling:
        sys.exit(f"rolling_shutter_eval: no TARGET frame of camera '{args.camera}' before its last")
    os.makedirs(args.out, exist_ok=True)
    for kind, views in (("rolling", rolling), ("global", plain)):
        path = os.path.join(args.out, f"views_{kind}.json")
        with open(path, "w") as f:
            json.dump({"cameras": clip["cameras"], "views": views}, f)
        for command in ([args.pf, "synth", "render", "--clip", args.clip, "--cameras", path,
                         "--out", os.path.join(args.out, f"truth_{kind}")],
                        [args.pf, "render", args.scene, "--cameras", path,
                         "--out", os.path.join(args.out, f"ours_{kind}")]):
            run = subprocess.run(command, capture_output=True, text=True)
            if run.returncode != 0:
                sys.exit(f"rolling_shutter_eval: {' '.join(command)}: {run.stderr.strip()}")
    out = lambda name: os.path.join(args.out, name)
    print(json.dumps({
        "views": len(rolling), "readoutUs": args.readout_us,
        "rollingAgainstRollingTruth": mean_psnr(out("ours_rolling"), out("truth_rolling")),
        "globalAgainstRollingTruth": mean_psnr(out("ours_global"), out("truth_rolling")),
        "globalAgainstGlobalTruth": mean_psnr(out("ours_global"), out("truth_global")),
        "globalTruthAgainstRollingTruth": mean_psnr(out("truth_global"), out("truth_rolling")),
    }))


if __name__ == "__main__":
    main()
