#!/usr/bin/env python3
"""Splatting's own gain (render.splat), scene by scene: each scene as given, rendered with `--splat on`
and `--splat off` at the same samples per pixel and seed, both against one reference rendered with
`--splat off` (an unbiased estimator of the same filtered image) at many samples and another seed.

Prints, per scene and sample count, each render's relative RMSE against the reference (sqrt of the mean
squared difference over pixels and channels, over the reference's mean: `vkpath compare`), its seconds
and samples/s (`--json`), and the ratios: MSE (off / on, at equal samples) and equal-time efficiency
(1 / (error^2 x seconds), on / off). Writes the same table as Markdown to --out.

    python3 benches/splat.py --binary target/release/vkpath --width 256 --spp 16 64 --ref-spp 1024 \
        SCENE.xml ... --out benches/results/splat-YYYY-MM-DD.md

Extra render flags go after `--` (Bitterli's files that name `$integrator`: `-- --xml-lenient -D integrator=path`, as
benches/peers/compare.py renders them).
"""

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile


def run(cmd, ok=(0,)):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode not in ok:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stderr}")
    return out.stdout


def render(args, scene, spp, seed, splat, path, extra):
    cmd = [args.binary, "render", scene, "--width", str(args.width), "--spp", str(spp),
           "--seed", str(seed), "--splat", splat, "-o", path, "--json", "--quiet"] + extra
    report = json.loads(run(cmd))
    return report


def compare(args, a, b):
    # Exit status 1: the images differ (they always do here).
    return json.loads(run([args.binary, "compare", a, b, "--json"], ok=(0, 1)))["rel_rmse"]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenes", nargs="+")
    p.add_argument("--binary", default="target/release/vkpath")
    p.add_argument("--width", type=int, default=256)
    p.add_argument("--spp", type=int, nargs="+", default=[16, 64])
    p.add_argument("--ref-spp", type=int, default=1024)
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
            name = os.path.basename(os.path.dirname(scene)) or scene
            ref = os.path.join(tmp, "ref.exr")
            r = render(args, scene, args.ref_spp, 7, "off", ref, extra)
            size = f"{r['width']}x{r['height']}"
            for spp in args.spp:
                res = {}
                for splat in ("on", "off"):
                    img = os.path.join(tmp, f"{splat}.exr")
                    rep = render(args, scene, spp, 1, splat, img, extra)
                    res[splat] = (compare(args, img, ref), rep["seconds"], rep["samples_per_second"])
                (e_on, t_on, s_on), (e_off, t_off, s_off) = res["on"], res["off"]
                mse_ratio = (e_off / e_on) ** 2
                eff = (e_off ** 2 * t_off) / (e_on ** 2 * t_on)
                row = (name, size, spp, e_on, e_off, s_on / 1e6, s_off / 1e6, mse_ratio, eff)
                rows.append(row)
                print("%-24s %-9s %4d spp  rel. RMSE on %.4f off %.4f  Msamples/s on %.3f off %.3f  "
                      "MSE off/on %.2f  efficiency on/off %.2f" % row, flush=True)
    if args.out:
        with open(args.out, "w") as f:
            f.write(f"# Splatting's gain (benches/splat.py), {datetime.date.today()}\n\n")
            f.write(f"{version} at {commit}; device: {device}; reference: --splat off, "
                    f"{args.ref_spp} spp, seed 7; measured renders seed 1; extra flags: "
                    f"{' '.join(extra) or 'none'}.\n\n")
            f.write("| scene | size | spp | rel. RMSE, splat on | off | Msamples/s on | off | "
                    "MSE off / on (equal samples) | efficiency on / off (equal time) |\n")
            f.write("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n")
            for r in rows:
                f.write("| %s | %s | %d | %.4f | %.4f | %.3f | %.3f | %.2f | %.2f |\n" % r)


if __name__ == "__main__":
    main()
