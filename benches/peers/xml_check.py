#!/usr/bin/env python3
"""One Mitsuba 3 XML file, rendered by vkpath (`vkpath render scene.xml`) and by Mitsuba 3 (`mi.load_file`),
the image means compared against their noise: the check that vkpath reads Mitsuba's scene files with
Mitsuba's meaning (issue 15). Prints one line per channel and the z-score of the difference.

    benches/peers/.venv/bin/python benches/peers/xml_check.py scenes/mitsuba/cornell-box.xml \\
        [--size 128] [--spp 1024] [--batches 16] [--vkpath target/release/vkpath]

vkpath's standard error comes from its own per-pixel variances (`--aov variance`: the variance of each
pixel's mean; the image mean's is their sum over P^2, the pixels being independent); Mitsuba's from the
spread of the means of `--batches` renders with different seeds. vkpath renders the file itself at
--size across (the film's aspect kept); Mitsuba a copy at that size (mitsuba_xml.py: includes inlined,
the film's size set, a custom default integrator set to path, rr_depth 3, which leaves the mean as is).
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--size", type=int, default=128, help="image width (the height keeps the film's aspect)")
    ap.add_argument("--spp", type=int, default=1024, help="samples per pixel, for each renderer")
    ap.add_argument("--batches", type=int, default=16, help="Mitsuba renders (seeds) the spp is split into")
    default_vkpath = ROOT / "target" / "release" / "vkpath"
    if not default_vkpath.exists():
        default_vkpath = ROOT / "target" / "debug" / "vkpath"
    ap.add_argument("--vkpath", type=Path, default=default_vkpath)
    ap.add_argument("--xml-lenient", action="store_true", help="pass --xml-lenient to vkpath")
    a = ap.parse_args()

    sys.path.insert(0, str(HERE))
    import mitsuba_xml as mx
    from compare import import_mitsuba

    import numpy as np
    import OpenEXR

    _, mi, _ = import_mitsuba()
    fw, fh = mx.film_size(a.scene)
    width, height = a.size, max(1, round(a.size * fh / fw))
    with tempfile.TemporaryDirectory() as tmp:
        exr = Path(tmp) / "vkpath.exr"
        # vkpath reads the file itself (its importer is what is checked); Mitsuba a copy with the same size
        # (mitsuba_xml.py: includes inlined, the film's size set, a custom default integrator -> path).
        flags = ["-D", "integrator=path"] if mx.custom_integrator(a.scene) else []
        flags += ["--xml-lenient"] if a.xml_lenient else []
        subprocess.run([str(a.vkpath), "render", str(a.scene), "--width", str(width), "--height", str(height),
                        "--spp", str(a.spp), "--aov", "variance", "-o", str(exr), "--quiet", *flags], check=True)
        copy = mx.copy(a.scene, Path(tmp) / "mitsuba.xml", width, height, "independent", 3, box=False)
        per_batch = max(1, a.spp // a.batches)
        scene = mi.load_file(str(copy))
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

    means = []
    for seed in range(a.batches):
        img = np.asarray(mi.render(scene, spp=per_batch, seed=seed), dtype=np.float64).reshape(-1, 3)
        means.append(img.mean(axis=0))
    means = np.array(means)
    m_mean = means.mean(axis=0)
    m_se = means.std(axis=0, ddof=1) / math.sqrt(a.batches)

    print(f"{a.scene}: {width}x{height}, vkpath {a.spp} spp, Mitsuba {a.batches} x {per_batch} spp "
          f"({mi.variant()}, Mitsuba {mi.__version__})")
    worst = 0.0
    for c, name in enumerate("RGB"):
        z = (v_mean[c] - m_mean[c]) / math.sqrt(v_se[c] ** 2 + m_se[c] ** 2)
        worst = max(worst, abs(z))
        print(f"  {name}: vkpath {v_mean[c]:.6f} +- {v_se[c]:.6f}   Mitsuba {m_mean[c]:.6f} +- {m_se[c]:.6f}"
              f"   ratio {v_mean[c] / m_mean[c]:.5f}   z {z:+.2f}")
    print(f"  largest |z| {worst:.2f} ({'within' if worst < 4 else 'BEYOND'} 4 standard errors)")
    return 0 if worst < 4 else 1


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    raise SystemExit(main())
