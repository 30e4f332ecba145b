#!/usr/bin/env python3
"""One Mitsuba 3 XML file, rendered by vkpath (`vkpath render scene.xml`) and by Mitsuba 3 (`mi.load_file`),
the image means compared against their noise: the check that vkpath reads Mitsuba's scene files with
Mitsuba's meaning (issues 15 and 28). Prints one line per channel and the z-score of the difference, a
per-block z-test (blocks of --block x --block pixels, the luminance; how many lie beyond 4 standard errors
against the number noise predicts, 6.3e-5 per block), each renderer's samples per second and the
equal-time error ratio.

    benches/peers/.venv/bin/python benches/peers/xml_check.py scenes/mitsuba/cornell-box.xml \\
        [--size 128] [--spp 1024] [--batches 16] [--vkpath target/release/vkpath]

vkpath's standard error comes from its own per-pixel variances (`--aov variance`: the variance of each
pixel's mean; the image mean's is their sum over P^2, the pixels being independent); Mitsuba's from the
spread of the means of `--batches` renders with different seeds. vkpath renders the file itself at
--size across (the film's aspect kept); Mitsuba a copy at that size (mitsuba_xml.py: includes inlined,
the film's size set, a custom default integrator set to path, rr_depth 3, which leaves the mean as is;
Mitsuba 0.x film parameters Mitsuba 3 refuses dropped).

Timing: vkpath's is the wall time of its whole `render` command (scene load, BVH build and kernel
compilation included); Mitsuba's the sum of its render calls after loading (its JIT compilation in the
first). Equal-time error ratio: sqrt(vkpath's mean per-pixel variance x its time / Mitsuba's x its time),
below 1 when vkpath reaches a given per-pixel error sooner.

Blocks at the image's edges (2026-12-05): Mitsuba 3's hdrfilm draws samples on the image only (its
`sample_border` is false by default), so an edge pixel's tent or Gaussian is cut off at the edge; vkpath
read such files with each pixel's filter whole until it learnt `render.sample_border`, and the edge rows
differed by up to 2.5 % (Bitterli's veach-mis: 16-18 of 144 blocks beyond 4 sigma, the floor's near edge
along the image's bottom; none once the filter is cut off alike, nor on the Cornell box, which had 9).
An earlier reading blamed the ratio estimator of Mitsuba's splatting: Mitsuba with 16x the samples per
batch (--mitsuba-spp) left the blocks as they were, which ruled it out. A block's luminance variance is
taken from each batch's luminance for Mitsuba and bounded by (sum_c w_c sd_c)^2 for vkpath, the
channels being correlated (summing w_c^2 var_c understated it by up to 1.34x in sd).
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--size", type=int, default=128, help="image width (the height keeps the film's aspect)")
    ap.add_argument("--spp", type=int, default=1024, help="samples per pixel, for each renderer")
    ap.add_argument("--batches", type=int, default=16, help="Mitsuba renders (seeds) the spp is split into")
    ap.add_argument("--mitsuba-spp", type=int, default=None,
                    help="Mitsuba's samples per pixel over all batches (default: --spp)")
    default_vkpath = ROOT / "target" / "release" / "vkpath"
    if not default_vkpath.exists():
        default_vkpath = ROOT / "target" / "debug" / "vkpath"
    ap.add_argument("--vkpath", type=Path, default=default_vkpath)
    ap.add_argument("--xml-lenient", action="store_true", help="pass --xml-lenient to vkpath")
    ap.add_argument("--block", type=int, default=8, help="block size in pixels for the per-block test")
    ap.add_argument("--seed", type=int, default=0,
                    help="vkpath's --seed, and Mitsuba's batches use seeds from seed x batches on (another "
                         "run's noise: a block flagged by noise moves, a real difference stays)")
    a = ap.parse_args()

    sys.path.insert(0, str(HERE))
    import mitsuba_xml as mx
    from compare import import_mitsuba

    import numpy as np
    import OpenEXR

    _, mi, _ = import_mitsuba()
    fw, fh = mx.film_size(a.scene)
    width, height = a.size, max(1, round(a.size * fh / fw))
    if width * fh != height * fw:
        # vkpath keeps the horizontal field of view when the size changes the aspect, Mitsuba the one on
        # its fov_axis: a file whose fov_axis is not x would be framed differently (veach_mis.xml at 64
        # across, 64x43 against 768x512, differed by 3 % in most 8x8 blocks while the means agreed).
        print(f"warning: {width}x{height} does not keep the film's aspect {fw}x{fh}; choose --size so that "
              f"it does (the two renderers may frame the scene differently)", file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        exr = Path(tmp) / "vkpath.exr"
        # vkpath reads the file itself (its importer is what is checked); Mitsuba a copy with the same size
        # (mitsuba_xml.py: includes inlined, the film's size set, a custom default integrator -> path).
        flags = ["-D", "integrator=path"] if mx.custom_integrator(a.scene) else []
        flags += ["--xml-lenient"] if a.xml_lenient else []
        t0 = time.perf_counter()
        try:
            # Through vkpath's Python module when this venv has it (benches/peers/setup.sh installs it).
            import vkpath as vk
        except ImportError:
            vk = None
        if vk is not None:
            defines = {"integrator": "path"} if flags[:1] == ["-D"] else {}
            s = vk.load(a.scene, xml_lenient=a.xml_lenient, **defines)
            s.set_size(width, height)
            r = s.render(spp=a.spp, seed=a.seed, aovs=["variance"])
            rgb, var = r.image, r.aovs["variance"]
        else:
            subprocess.run([str(a.vkpath), "render", str(a.scene), "--width", str(width), "--height", str(height),
                            "--spp", str(a.spp), "--seed", str(a.seed), "--aov", "variance", "-o", str(exr),
                            "--quiet", *flags], check=True)
        v_time = time.perf_counter() - t0
        copy = mx.copy(a.scene, Path(tmp) / "mitsuba.xml", width, height, "independent", 3, box=False)
        per_batch = max(1, (a.mitsuba_spp or a.spp) // a.batches)
        scene = mi.load_file(str(copy))
        if vk is None:
            with OpenEXR.File(str(exr)) as f:
                ch = f.channels()
                rgb = ch["RGB"].pixels if "RGB" in ch else np.stack([ch[c].pixels for c in "RGB"], axis=-1)
                # The OpenEXR module groups a layer's channels (variance.R, .G, .B) under the layer's name.
                var = ch["variance"].pixels
    rgb = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
    var = np.asarray(var, dtype=np.float64).reshape(-1, 3)
    p = rgb.shape[0]
    v_mean = rgb.mean(axis=0)
    v_se = np.sqrt(var.sum(axis=0)) / p

    imgs = []
    m_time = 0.0
    for seed in range(a.batches):
        t0 = time.perf_counter()
        img = np.asarray(mi.render(scene, spp=per_batch, seed=a.seed * a.batches + seed), dtype=np.float64)
        m_time += time.perf_counter() - t0
        imgs.append(img.reshape(-1, 3))
    imgs = np.array(imgs)  # batches x pixels x 3
    means = imgs.mean(axis=1)
    m_mean = means.mean(axis=0)
    m_se = means.std(axis=0, ddof=1) / math.sqrt(a.batches)
    # Per pixel: Mitsuba's variance of its mean over the batches, vkpath's from its AOV.
    m_var = imgs.var(axis=0, ddof=1) / a.batches

    # Per-block z-test on the luminance (Rec. 709 weights; its variance below).
    lum = np.array([0.2126, 0.7152, 0.0722])
    bx, by = max(1, width // a.block), max(1, height // a.block)
    def blocks(x):
        x = x.reshape(height, width)[: by * a.block, : bx * a.block]
        return x.reshape(by, a.block, bx, a.block).mean(axis=(1, 3))
    def block_var(v):
        v = v.reshape(height, width)[: by * a.block, : bx * a.block]
        return v.reshape(by, a.block, bx, a.block).sum(axis=(1, 3)) / (a.block * a.block) ** 2
    v_blocks = blocks(rgb @ lum)
    m_blocks = blocks(imgs.mean(axis=0) @ lum)
    # A block both renderers see without noise (the environment alone) has no variance: it agrees when
    # the values do (z 0), else it is infinitely far.
    diff = v_blocks - m_blocks
    # A pixel's channels are strongly correlated (one path carries all three), so the luminance's
    # variance is not the weighted sum of the channels' variances (which understated it by up to 1.34x in
    # sd on grey scenes and so inflated z). Mitsuba's: exact, from each batch's luminance. vkpath's AOV has
    # the channels' variances only: its bound for correlation 1, (sum_c w_c sd_c)^2, which cannot
    # understate it.
    m_lum_var = (imgs @ lum).var(axis=0, ddof=1) / a.batches
    v_lum_var = (np.sqrt(var) @ lum) ** 2
    # Both renderers store f32 pixels: where a block is nearly noiseless (inside a light) its values agree
    # only to f32 rounding, so differences below 1e-5 of the value count as agreement (a floor on sd).
    sd = np.sqrt(block_var(v_lum_var) + block_var(m_lum_var) + (1e-5 * np.abs(m_blocks)) ** 2)
    z_blocks = np.where(sd > 0, diff / np.where(sd > 0, sd, 1.0),
                        np.where(np.abs(diff) <= 1e-6 * np.abs(m_blocks), 0.0, np.inf))
    beyond = int((np.abs(z_blocks) > 4).sum())
    expected = 6.334e-5 * z_blocks.size

    print(f"{a.scene}: {width}x{height}, vkpath {a.spp} spp, Mitsuba {a.batches} x {per_batch} spp "
          f"({mi.variant()}, Mitsuba {mi.__version__})")
    worst = 0.0
    for c, name in enumerate("RGB"):
        z = (v_mean[c] - m_mean[c]) / math.sqrt(v_se[c] ** 2 + m_se[c] ** 2)
        worst = max(worst, abs(z))
        print(f"  {name}: vkpath {v_mean[c]:.6f} +- {v_se[c]:.6f}   Mitsuba {m_mean[c]:.6f} +- {m_se[c]:.6f}"
              f"   ratio {v_mean[c] / m_mean[c]:.5f}   z {z:+.2f}")
    print(f"  largest |z| {worst:.2f} ({'within' if worst < 4 else 'BEYOND'} 4 standard errors)")
    print(f"  blocks of {a.block}x{a.block}: {beyond} of {z_blocks.size} beyond 4 sigma (noise predicts "
          f"{expected:.3f}); largest |z| {np.abs(z_blocks).max():.2f}")
    for by_, bx_ in zip(*np.nonzero(np.abs(z_blocks) > 4)):
        print(f"    block at pixel ({bx_ * a.block}, {by_ * a.block}): vkpath {v_blocks[by_, bx_]:.5f}, "
              f"Mitsuba {m_blocks[by_, bx_]:.5f}, z {z_blocks[by_, bx_]:+.2f}")
    samples = width * height * a.spp
    m_samples = width * height * per_batch * a.batches
    # (Variance x time does not depend on the sample count: the ratio holds for unequal spp.)
    eq = math.sqrt(var.mean() * v_time / (m_var.mean() * m_time))
    print(f"  vkpath {samples / v_time / 1e6:.3f} Msamples/s ({v_time:.1f} s, load and compile included), "
          f"Mitsuba {m_samples / m_time / 1e6:.3f} Msamples/s ({m_time:.1f} s); equal-time error ratio "
          f"vkpath / Mitsuba {eq:.2f}")
    # Blocks beyond 4 sigma: more than noise predicts when at least 2 (P(>= 2) < 1e-3 for the block
    # counts used here).
    return 0 if worst < 4 and beyond < 2 else 1


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    raise SystemExit(main())
