#!/usr/bin/env python3
"""Adaptive sampling's own gain (render.adaptive), scene by scene: each scene as given, rendered at the same
most samples per pixel and seed by the default estimator (splatted where the scene's filter splats), by the
per-pixel estimator (`--splat off`), and adaptively (`--adaptive-threshold T`, which keeps each pixel's own
samples), all against one `--splat off` reference at many samples and another seed.

Prints, per scene and arm, the MSE (over pixels and channels) and relMSE (mean of (a - r)^2 / (r^2 + 0.01)
over pixels, channels averaged first) against the reference, the mean samples per pixel, the seconds
(`--json`), and the equal-time efficiency against the default arm: (error x seconds of the default) /
(error x seconds of the arm), for MSE and for relMSE (above 1: the arm reaches a given error sooner).
Writes the same table as Markdown to --out.

    benches/peers/.venv/bin/python benches/adaptive.py --binary target/release/vkpath --width 512 \
        --height 512 --spp 256 --ref-spp 2048 --thresholds 0.05 0.02 scenes/course.toml ... \
        --out benches/results/adaptive-YYYY-MM-DD.md

Needs numpy and OpenEXR (benches/peers/setup.sh installs both in benches/peers/.venv). Extra render flags
go after `--` (Bitterli's files that name `$integrator`, all but the living room:
`-- --xml-lenient -D integrator=path`; a `-D` the file does not use is an error).
"""

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "peers"))
from compare import read_exr  # noqa: E402


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stderr}")
    return out.stdout


def render(args, scene, spp, seed, flags, path, extra):
    cmd = [args.binary, "render", scene, "--width", str(args.width), "--height", str(args.height),
           "--spp", str(spp),
           "--seed", str(seed), "-o", path, "--json", "--quiet"] + flags + extra
    return json.loads(run(cmd))


def errors(img, ref):
    import numpy as np
    mse = float(np.mean((img - ref) ** 2))
    r = ref.mean(axis=-1)
    rel = float(np.mean(((img - ref) ** 2).mean(axis=-1) / (r * r + 0.01)))
    return mse, rel


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenes", nargs="+")
    p.add_argument("--binary", default="target/release/vkpath")
    p.add_argument("--width", type=int, default=512)
    p.add_argument("--height", type=int, default=512)
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--ref-spp", type=int, default=2048)
    p.add_argument("--thresholds", type=float, nargs="+", default=[0.05, 0.02])
    p.add_argument("--out")
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    args = p.parse_args(argv)
    version = run([args.binary, "--version"]).strip()
    info = json.loads(run([args.binary, "info", "--json"]))
    chosen = info["devices"][info["chosen"]]
    device = f"{chosen['name']}, {chosen['driver']}"
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in args.scenes:
            name = os.path.splitext(os.path.basename(scene))[0]
            if name == "scene":
                name = os.path.basename(os.path.dirname(scene))
            ref_path = os.path.join(tmp, "ref.exr")
            r = render(args, scene, args.ref_spp, 7, ["--splat", "off"], ref_path, extra)
            ref = read_exr(ref_path)
            size = f"{r['width']}x{r['height']}"
            arms = [("default", []), ("per-pixel", ["--splat", "off"])]
            arms += [(f"adaptive {t:g}", ["--adaptive-threshold", str(t)]) for t in args.thresholds]
            base = None
            for label, flags in arms:
                path = os.path.join(tmp, "arm.exr")
                rep = render(args, scene, args.spp, 1, flags, path, extra)
                mse, rel = errors(read_exr(path), ref)
                t = rep["seconds"]
                if base is None:
                    base = (mse, rel, t)
                row = (name, size, label, rep["mean_spp"], t, mse, rel,
                       base[0] * base[2] / (mse * t), base[1] * base[2] / (rel * t))
                rows.append(row)
                print("%-22s %-9s %-15s mean spp %6.1f  %7.2f s  MSE %.3e  relMSE %.3e  "
                      "efficiency vs default: MSE %.2f relMSE %.2f" % row, flush=True)
    if args.out:
        with open(args.out, "w") as f:
            f.write(f"# Adaptive sampling's gain (benches/adaptive.py), {datetime.date.today()}\n\n")
            f.write(f"{version} at {commit}; device: {device}; reference: --splat off, "
                    f"{args.ref_spp} spp, seed 7; measured renders: at most {args.spp} spp, seed 1; "
                    f"extra flags: {' '.join(extra) or 'none'}.\n\n")
            f.write("| scene | size | arm | mean spp | seconds | MSE | relMSE | "
                    "efficiency vs default (MSE) | (relMSE) |\n")
            f.write("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n")
            for r in rows:
                f.write("| %s | %s | %s | %.1f | %.2f | %.3e | %.3e | %.2f | %.2f |\n" % r)


if __name__ == "__main__":
    main()
