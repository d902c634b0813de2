#!/usr/bin/python3
"""The real-clip evaluation suite: builds clips from the sample data, evaluates each with
the analytic and the pixel-aligned models, and prints one table (docs/QUALITY.md).

Each clip is imported from ../shared/data (PF_DATA_DIR) with `pf import`, its frame roles
set by the split below, then `pf eval CLIP --out DIR [--model pixel-aligned]` runs under
/usr/bin/time for the peak memory. Per clip the table has our PSNR and SSIM, the
pixel-aligned model's, the baselines every report.json carries (`nearest`: the nearest
CONTEXT image of the target's camera; `warp`: the two nearest CONTEXT frames forward-warped
with LiDAR depth completed by IP-Basic), the PSNR of each over the moving actors' pixels
(report.json's dynamicPsnr), the depth error of our render against the LiDAR of the
TARGET times, the reconstruction time and the peak memory.

usage: scripts/eval_suite.py [--pf PATH] [--data DIR] [--out DIR] [--clips A,B] [--quick]
                             [--no-pixel-aligned] [--json FILE] [--list] [--eval-args ARGS]
                             [--depth | --depth-only] [--lidar-as-depth-maps] [--bands N]
  --quick   one tiny PandaSet clip (front camera, frames 30-33, quarter resolution): a
            check that the suite runs (ctest eval_suite_quick), not a measurement.
  --eval-args  more flags for every `pf eval`, one string (e.g. "--working-space linear");
            `pf depth-eval` takes the depth-stage ones among them.
  --depth   also `pf depth-eval CLIP --hide half` and `--hide top` per clip: the dense depth
            of the CONTEXT views at LiDAR points hidden from the depth stage, ours beside
            LiDAR completion alone (nearest) and IP-Basic; a second table.
  --depth-only  only that (no pf eval).
  --lidar-as-depth-maps  import each clip with its LiDAR written as a sparse depth map per
            frame (`pf import ... --lidar-as-depth-maps`), as rigs that give depth maps do.
  --bands N  also split each clip's error by image rows: N horizontal bands, top to bottom
            (default 3; 0: none), ours (the contact sheets' truth and render) beside the
            nearest CONTEXT image of the camera, each the mean PSNR over the TARGET frames;
            a third table, and "bands" in --json. Each frame's bands, pooled, must give
            report.json's squared error to 2 % (the suite fails otherwise). Needs numpy and
            OpenImageIO (Debian's python3-numpy, python3-openimageio).
  Exit 0 when every evaluation ran, 1 when one failed, 2 for bad usage, 77 when the
  sample data is missing (ctest reports the test skipped).
"""
import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# A split gives each frame its role from (camera, the frame's index among that camera's
# frames in time order, their count): True for CONTEXT.
SPLITS = {
    # DGP samples: 3 timestamps about 1 s apart.
    "middle": lambda cam, i, n: i != n // 2,           # context first and last, target middle
    "last": lambda cam, i, n: i < n - 1,                # context all but the last (extrapolation)
    # PandaSet: context every other frame, the frames between are targets.
    "alternate": lambda cam, i, n: i % 2 == 0,
    # Targets on a camera that gives no context: context every other frame of the other
    # cameras, targets the odd frames of the front camera.
    "cross_camera": lambda cam, i, n: cam != "front_camera" and i % 2 == 0,
}
CROSS_CAMERA_TARGETS = lambda cam, i, n: cam == "front_camera" and i % 2 == 1

# name -> (importer, source under the data dir, extra import flags, split)
CLIPS = {
    "dgp01_middle": ("dgp", "dgp_test_scene/scene_01", [], "middle"),
    "dgp01_last": ("dgp", "dgp_test_scene/scene_01", [], "last"),
    "dgp02_middle": ("dgp", "dgp_test_scene/scene_02", [], "middle"),
    "dgp02_last": ("dgp", "dgp_test_scene/scene_02", [], "last"),
    "pandaset_half": ("pandaset", "pandaset_002", ["--scale", "0.5"], "alternate"),
    "pandaset_full": ("pandaset", "pandaset_002", [], "alternate"),
    # The first 8 frames only (24 views): a quicker check of a change.
    "pandaset_half_8": ("pandaset", "pandaset_002", ["--scale", "0.5", "--frames", "30:38"],
                        "alternate"),
    "pandaset_half_8_cross_camera": ("pandaset", "pandaset_002",
                                     ["--scale", "0.5", "--frames", "30:38"], "cross_camera"),
    "pandaset_half_cross_camera": ("pandaset", "pandaset_002", ["--scale", "0.5"],
                                   "cross_camera"),
}
QUICK = {
    "quick": ("pandaset", "pandaset_002",
              ["--scale", "0.25", "--frames", "30:33", "--cameras", "front_camera"], "alternate"),
}


def run(argv, log):
    """Runs argv, appending its output to `log`; returns (exit code, seconds)."""
    start = time.monotonic()
    with open(log, "a") as out:
        out.write("$ " + " ".join(argv) + "\n")
        out.flush()
        code = subprocess.call(argv, stdout=out, stderr=subprocess.STDOUT)
    return code, time.monotonic() - start


def set_roles(manifest, split):
    """Rewrites the frame roles of clip.json at `manifest` by `split`."""
    with open(manifest) as f:
        clip = json.load(f)
    by_camera = {}
    for frame in clip["frames"]:
        by_camera.setdefault(frame["camera"], []).append(frame)
    for camera, frames in by_camera.items():
        frames.sort(key=lambda fr: int(fr["timestampUs"]))
        for i, frame in enumerate(frames):
            context = SPLITS[split](camera, i, len(frames))
            if split == "cross_camera":
                target = CROSS_CAMERA_TARGETS(camera, i, len(frames))
                if not context and not target:
                    frame["role"] = "DROP"
                    continue
            frame["role"] = "CONTEXT" if context else "TARGET"
    clip["frames"] = [fr for fr in clip["frames"] if fr["role"] != "DROP"]
    with open(manifest, "w") as f:
        json.dump(clip, f, indent=1)
    roles = [fr["role"] for fr in clip["frames"]]
    return roles.count("CONTEXT"), roles.count("TARGET")


def peak_gib(time_log):
    """The peak RSS /usr/bin/time -f '%M' wrote (KiB), in GiB."""
    try:
        with open(time_log) as f:
            return int(f.read().split()[-1]) / 2**20
    except (OSError, ValueError, IndexError):
        return None


def figure(report, *keys):
    value = report
    for key in keys:
        if not isinstance(value, dict) or value.get(key) is None:
            return None
        value = value[key]
    return value


def evaluate(pf, clip_json, out_dir, model, log, eval_args):
    """Runs pf eval; returns the row's figures for this model, or None when it failed."""
    time_log = out_dir + ".time"
    argv = ["/usr/bin/time", "-o", time_log, "-f", "%M", pf, "eval", clip_json, "--out", out_dir]
    if model != "analytic":
        argv += ["--model", model]
    argv += eval_args
    code, seconds = run(argv, log)
    if code != 0:
        return None
    with open(os.path.join(out_dir, "report.json")) as f:
        report = json.load(f)
    return {
        "psnr": figure(report, "mean", "psnr"),
        "ssim": figure(report, "mean", "ssim"),
        "lidarAbsRel": figure(report, "mean", "lidarAbsRel"),
        "nearestPsnr": figure(report, "baselines", "nearest", "psnr"),
        "nearestSsim": figure(report, "baselines", "nearest", "ssim"),
        "warpPsnr": figure(report, "baselines", "warp", "psnr"),
        "warpSsim": figure(report, "baselines", "warp", "ssim"),
        "warpLidarAbsRel": figure(report, "baselines", "warp", "lidarAbsRel"),
        "dynamicPsnr": figure(report, "mean", "dynamicPsnr"),
        "nearestDynamicPsnr": figure(report, "baselines", "nearest", "dynamicPsnr"),
        "warpDynamicPsnr": figure(report, "baselines", "warp", "dynamicPsnr"),
        "reconstructSeconds": report.get("reconstructSeconds"),
        "evalSeconds": seconds,
        "peakGiB": peak_gib(time_log),
        "gaussians": report.get("gaussians"),
    }


def band_split(clip_json, eval_dir, bands):
    """Per image band (rows, top to bottom), the mean over the TARGET frames of ours and the
    nearest CONTEXT image's PSNR, from eval_dir's report.json and contact sheets; raises
    ValueError when a frame's sheet does not give its report.json PSNR."""
    import numpy as np
    import OpenImageIO as oiio

    def load(path):
        pixels = oiio.ImageBuf(path).get_pixels(oiio.FLOAT)
        if pixels is None or pixels.size == 0:
            raise ValueError(f"cannot read {path}")
        return pixels[:, :, :3]

    def psnr(mse):
        return float(-10 * np.log10(max(mse, 1e-12)))

    with open(clip_json) as f:
        clip = json.load(f)
    with open(os.path.join(eval_dir, "report.json")) as f:
        report = json.load(f)
    images = {(frame["camera"], int(frame["timestampUs"])):
              os.path.join(os.path.dirname(clip_json), frame["image"])
              for frame in clip["frames"]}
    ours, nearest = [[] for _ in range(bands)], [[] for _ in range(bands)]
    for frame in report.get("frames", []):
        sheet = load(os.path.join(eval_dir, os.path.basename(frame["contactSheet"])))
        width = sheet.shape[1] // 3
        truth, render = sheet[:, :width], sheet[:, width:2 * width]
        error = ((truth - render) ** 2).mean(axis=2)
        # The sheet's 8-bit render adds about (1/255)^2 / 12 to the squared error.
        if frame.get("psnr") is not None:
            reported = 10 ** (-frame["psnr"] / 10)
            if abs(float(error.mean()) - reported) > 0.02 * reported + 3e-6:
                raise ValueError(f"{frame['contactSheet']}: the sheet gives "
                                 f"{psnr(error.mean()):.3f} dB, report.json {frame['psnr']:.3f}")
        rows = np.array_split(np.arange(error.shape[0]), bands)
        for b, band in enumerate(rows):
            ours[b].append(psnr(error[band].mean()))
        # The CONTEXT frame pf eval took as the nearest baseline (another camera's,
        # resized, on a split whose target camera gives no context: left out).
        near = (frame.get("baselines", {}).get("nearest") or {}).get("frames") or []
        if near:
            image = load(images[(near[0]["camera"], int(near[0]["timestampUs"]))])
            if image.shape == truth.shape:
                near_error = ((truth - image) ** 2).mean(axis=2)
                for b, band in enumerate(rows):
                    nearest[b].append(psnr(near_error[band].mean()))
    mean = lambda values: sum(values) / len(values) if values else None
    return {"ours": [mean(v) for v in ours], "nearest": [mean(v) for v in nearest]}


DEPTH_STAGE_FLAGS = {"--completion": 1, "--no-ground-fill": 0, "--no-facades": 0, "--no-stereo": 0,
                     "--working-space": 1, "--allow-outside-paths": 0}


def depth_stage_args(eval_args):
    """The flags of `eval_args` that pf depth-eval takes (the depth stage's)."""
    out, i = [], 0
    while i < len(eval_args):
        takes = DEPTH_STAGE_FLAGS.get(eval_args[i])
        if takes is None:
            i += 1
            continue
        out += eval_args[i:i + 1 + takes]
        i += 1 + takes
    return out


def depth_evaluate(pf, clip_json, out_dir, hide, log, eval_args):
    """Runs pf depth-eval --hide `hide`; returns its JSON, or None when it failed."""
    json_path = os.path.join(out_dir, f"depth_{hide}.json")
    os.makedirs(out_dir, exist_ok=True)
    code, _ = run([pf, "depth-eval", clip_json, "--hide", hide, "--json", json_path] +
                  depth_stage_args(eval_args), log)
    if code != 0:
        return None
    with open(json_path) as f:
        return json.load(f)


def fmt(value, digits=2):
    return "-" if value is None else f"{value:.{digits}f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pf", default=os.path.join(ROOT, "build", "bin", "pf"))
    parser.add_argument("--data", default=os.environ.get(
        "PF_DATA_DIR", os.path.join(ROOT, "..", "shared", "data")))
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "eval-suite"))
    parser.add_argument("--clips", default="")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--no-pixel-aligned", action="store_true")
    parser.add_argument("--json", default="")
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--eval-args", default="")
    parser.add_argument("--depth", action="store_true")
    parser.add_argument("--depth-only", action="store_true")
    parser.add_argument("--lidar-as-depth-maps", action="store_true")
    parser.add_argument("--bands", type=int, default=3)
    args = parser.parse_args()
    if args.bands < 0:
        print("eval_suite: --bands: must be 0 or more", file=sys.stderr)
        return 2

    clips = QUICK if args.quick else CLIPS
    if args.list:
        for name, (importer, source, flags, split) in clips.items():
            print(f"{name}: pf import {importer} {source} {' '.join(flags)}; split {split}")
        return 0
    names = [c for c in args.clips.split(",") if c] or list(clips)
    unknown = [n for n in names if n not in clips]
    if unknown:
        print(f"eval_suite: unknown clip(s) {', '.join(unknown)} (have {', '.join(clips)})",
              file=sys.stderr)
        return 2
    if not os.path.isfile(args.pf):
        print(f"eval_suite: no pf at {args.pf} (make build, or --pf PATH)", file=sys.stderr)
        return 2
    missing = sorted({clips[n][1] for n in names
                      if not os.path.isdir(os.path.join(args.data, clips[n][1]))})
    if missing:
        print(f"eval_suite: sample data {', '.join(missing)} not found under {args.data}: set "
              "PF_DATA_DIR (or --data) to the shared/data directory", file=sys.stderr)
        return 77

    os.makedirs(args.out, exist_ok=True)
    log = os.path.join(args.out, "suite.log")
    models = [] if args.depth_only else (
        ["analytic"] + ([] if args.no_pixel_aligned else ["pixel-aligned"]))
    hides = ["half", "top"] if args.depth or args.depth_only else []
    rows, failed = [], []
    for name in names:
        importer, source, flags, split = clips[name]
        clip_dir = os.path.join(args.out, name, "clip")
        subprocess.call(["rm", "-rf", os.path.join(args.out, name)])
        code, _ = run([args.pf, "import", importer, os.path.join(args.data, source), "--out",
                       clip_dir] + flags +
                      (["--lidar-as-depth-maps"] if args.lidar_as_depth_maps else []), log)
        if code != 0:
            failed.append(f"{name}: pf import exited {code}")
            continue
        context, target = set_roles(os.path.join(clip_dir, "clip.json"), split)
        row = {"clip": name, "context": context, "target": target}
        for model in models:
            figures = evaluate(args.pf, os.path.join(clip_dir, "clip.json"),
                               os.path.join(args.out, name, model), model, log,
                               args.eval_args.split())
            if figures is None:
                failed.append(f"{name}: pf eval --model {model} failed")
                continue
            row[model] = figures
            if model == "analytic" and args.bands > 0:
                try:
                    row["bands"] = band_split(os.path.join(clip_dir, "clip.json"),
                                              os.path.join(args.out, name, model), args.bands)
                except (ImportError, OSError, ValueError, KeyError) as e:
                    failed.append(f"{name}: the band split failed: {e}")
        for hide in hides:
            depth = depth_evaluate(args.pf, os.path.join(clip_dir, "clip.json"),
                                   os.path.join(args.out, name, "depth"), hide, log,
                                   args.eval_args.split())
            if depth is None:
                failed.append(f"{name}: pf depth-eval --hide {hide} failed")
                continue
            row[f"depth_{hide}"] = depth
        rows.append(row)
        print(f"eval_suite: {name} done", file=sys.stderr, flush=True)

    if models:
        print_eval_table(rows)
    if models and args.bands > 0:
        print_band_table(rows, args.bands)
    if hides:
        print_depth_table(rows, hides)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    for problem in failed:
        print(f"eval_suite: {problem} (log: {log})", file=sys.stderr)
    return 1 if failed else 0


def print_depth_table(rows, hides):
    """Dense depth at hidden LiDAR points: AbsRel / within 5 % / coverage per method."""
    header = ("| clip | hidden | points | nearest AbsRel | ip-basic AbsRel | ours AbsRel | "
              "nearest within 5 % | ip-basic within 5 % | ours within 5 % | "
              "nearest coverage | ip-basic coverage | ours coverage | ours common AbsRel "
              "(nearest) |")
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for row in rows:
        for hide in hides:
            depth = row.get(f"depth_{hide}")
            if depth is None:
                continue
            m = depth["methods"]
            cells = [m[k]["absRel"] for k in ("nearest", "ipBasic", "ours")]
            cells += [m[k]["within5"] for k in ("nearest", "ipBasic", "ours")]
            cells += [m[k]["coverage"] for k in ("nearest", "ipBasic", "ours")]
            print(f"| {row['clip']} | {hide} | {depth['hiddenPoints']} | " +
                  " | ".join(fmt(c, 3) for c in cells) +
                  f" | {fmt(m['ours']['common']['absRel'], 3)} "
                  f"({fmt(m['nearest']['common']['absRel'], 3)}) |")


def print_band_table(rows, bands):
    """Ours and the nearest CONTEXT image per image band, top to bottom."""
    header = ("| clip | " + " | ".join(f"band {b + 1} ours / nearest" for b in range(bands)) +
              " |")
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for row in rows:
        split = row.get("bands")
        if split is None:
            continue
        print(f"| {row['clip']} | " + " | ".join(
            f"{fmt(split['ours'][b])} / {fmt(split['nearest'][b])}" for b in range(bands)) + " |")


def print_eval_table(rows):
    header = ("| clip | context / target views | ours PSNR | pixel-aligned | nearest | warp | "
              "ours SSIM | nearest SSIM | warp SSIM | moving actors PSNR ours / nearest / warp | "
              "depth AbsRel ours / warp | reconstruction s | peak GiB | Gaussians |")
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for row in rows:
        ours = row.get("analytic", {})
        pixel = row.get("pixel-aligned", {})
        print(f"| {row['clip']} | {row['context']} / {row['target']} | {fmt(ours.get('psnr'))} | "
              f"{fmt(pixel.get('psnr'))} | {fmt(ours.get('nearestPsnr'))} | "
              f"{fmt(ours.get('warpPsnr'))} | {fmt(ours.get('ssim'), 3)} | "
              f"{fmt(ours.get('nearestSsim'), 3)} | {fmt(ours.get('warpSsim'), 3)} | "
              f"{fmt(ours.get('dynamicPsnr'))} / {fmt(ours.get('nearestDynamicPsnr'))} / "
              f"{fmt(ours.get('warpDynamicPsnr'))} | "
              f"{fmt(ours.get('lidarAbsRel'), 3)} / {fmt(ours.get('warpLidarAbsRel'), 3)} | "
              f"{fmt(ours.get('reconstructSeconds'), 1)} | {fmt(ours.get('peakGiB'))} | "
              f"{ours.get('gaussians', '-')} |")


if __name__ == "__main__":
    sys.exit(main())
