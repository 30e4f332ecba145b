#!/usr/bin/env python3
"""vkpath vs Mitsuba 3: samples/s, and relative error against a common reference at equal time.

Run benches/peers/setup.sh once (it installs vkpath's Python module from this checkout into the venv,
through which vkpath renders; `--vkpath-via binary` runs the release binary instead: cargo build
--release), then from the repository root:

    benches/peers/.venv/bin/python benches/peers/compare.py            # the course scenes, 128x128
    benches/peers/.venv/bin/python benches/peers/compare.py --quick    # a 1-2 minute smoke run

For each scene (a copy with `filter = "box"` and the requested size; see mitsuba_scene.py for how it is
translated), it renders:

1. the common reference: `--ref-spp` samples per pixel from EACH renderer, in `--ref-batches`
   independent batches, averaged (the reference is the mean of the two). Both renderers take part so that
   the reference favours neither; the batches give a per-pixel variance, hence the reference's own noise
   (subtracted from the squared errors below) and the unbiasedness check: the two renderers' reference
   images must differ only by their noise (the ratio of the observed mean squared difference to the
   expected one is ~1, the image means agree within their standard error, no 16x16-pixel block is off by
   more than ~4 standard errors).
2. a ladder of renders at 1, 2, 4, ... `--max-spp` spp for each renderer (each vkpath `--vkpath-config`,
   and Mitsuba), with seeds distinct from the reference's; for each: seconds, samples/s and
   relative error = sqrt(mean over pixels and channels of (img - ref)^2) / mean(ref),
   reported both raw and with the reference's expected squared noise subtracted (`rel_error`, the one the
   tables use; unbiased for the error against the true image).

Timing: vkpath's is the `seconds` field of `vkpath render --json` (the render loop: the device, the
pipelines and the scene upload come before it). Mitsuba's is the wall clock of `mi.render` up to the
finished image (`dr.sync_thread()`), after one untimed warm-up render of the same scene that compiles (or
loads from Dr.Jit's cache) the kernel; each timed call still pays Mitsuba's per-call tracing of the
integrator, which is part of what a user pays per render. The two renderers never run at once.

From each ladder: a time model seconds = a + b spp fitted to its renders (single renders on a shared
machine take load spikes; the measured seconds stay in the ladder CSV), samples/s = pixels / b, the time
to reach 5%, 2% and 1% relative error (piecewise linear interpolation of log(error) against
log(modelled seconds) between the renders; beyond the last render, error = c / sqrt(seconds) from its last
three renders, marked with ~ in the table) and the error at equal time (the longest time that every
renderer's ladder reached on that scene, interpolated the same way): the figure of merit.

Several vkpath settings can be compared in one run: each `--vkpath-config 'LABEL:FLAGS'` is a ladder of its
own (e.g. `--vkpath-config 'mis:--light-sampling mis' --vkpath-config 'none:--light-sampling none'`), a row
per scene in the main table and a column in the side-by-side tables (error at equal time, noise per sample;
configs in the order given, then Mitsuba). The first config renders the reference with Mitsuba; with
--check-every-config every config also renders reference batches and is checked against Mitsuba's (one
unbiasedness row per config).

Outputs, under --out (default benches/peers/results/): <tag>-ladder.csv (every render),
<tag>-summary.csv (per scene and renderer), <tag>-reference.csv (the unbiasedness check), <tag>.md
(the tables, also printed), images/<tag>/ (the reference EXRs; git-ignored), tmp/ (scene copies).
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import glob
import json
import math
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))

import mitsuba_scene as ms  # noqa: E402
import mitsuba_xml as mx  # noqa: E402

TARGETS = (0.05, 0.02, 0.01)


# ---------------------------------------------------------------------------------------------------
# Environment: Dr.Jit's LLVM back end needs LLVM 19 (the LLVM 15 that Mesa pulls in crashes it)
# ---------------------------------------------------------------------------------------------------


def find_llvm19() -> str | None:
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    patterns = [
        "/usr/lib/*/libLLVM.so.19*",
        "/usr/lib/*/libLLVM-19.so*",
        "/usr/lib/llvm-19/lib/libLLVM*.so*",
    ]
    for p in patterns:
        hits = sorted(glob.glob(p))
        if hits:
            return hits[0]
    return None


def import_mitsuba():
    llvm = find_llvm19()
    if llvm is None:
        sys.exit("compare.py: no LLVM 19 shared library found; run benches/peers/setup.sh "
                 "(or set DRJIT_LIBLLVM_PATH)")
    os.environ["DRJIT_LIBLLVM_PATH"] = llvm
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError:
        sys.exit("compare.py: mitsuba is not importable; run with benches/peers/.venv/bin/python after "
                 "benches/peers/setup.sh")
    mi.set_variant("llvm_ad_rgb")
    return dr, mi, llvm


# ---------------------------------------------------------------------------------------------------
# Images
# ---------------------------------------------------------------------------------------------------


def read_exr(path: str | os.PathLike):
    import numpy as np
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            img = ch["RGB"].pixels
        else:
            img = np.stack([ch[c].pixels for c in ("R", "G", "B")], axis=-1)
    return np.asarray(img, dtype=np.float64)


def write_exr(path: str | os.PathLike, img) -> None:
    import numpy as np
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(img, dtype=np.float32)}) as f:
        f.write(str(path))


# ---------------------------------------------------------------------------------------------------
# Renderers
# ---------------------------------------------------------------------------------------------------


@dataclass
class Render:
    img: object
    seconds: float
    spp: int
    info: dict = field(default_factory=dict)


class Vkpath:
    def __init__(self, binary: Path, label: str, extra_args: list[str], scene_toml: Path, tmp: Path):
        self.binary, self.label, self.extra = binary, label, extra_args
        self.scene_toml, self.tmp = scene_toml, tmp

    def render(self, spp: int, seed: int) -> Render:
        out = self.tmp / f"vkpath-{os.getpid()}.exr"
        cmd = [str(self.binary), "render", str(self.scene_toml), "--spp", str(spp), "--seed", str(seed),
               "--json", "--quiet", "-o", str(out), *self.extra]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr}")
        info = json.loads(p.stdout.strip().splitlines()[-1])
        if info.get("spp") != spp:
            raise RuntimeError(f"vkpath rendered {info.get('spp')} spp, asked for {spp}")
        img = read_exr(out)
        out.unlink()
        return Render(img, float(info["seconds"]), spp, info)


class VkpathModule:
    """The same renders through vkpath's Python module (`import vkpath`; setup.sh installs it in the venv
    from this checkout): the scene is read once per config and each render comes back as an array, with
    no process start and no EXR between them. The timing is the same `seconds` field (the render loop).
    The config's flags become the module's arguments; a flag with no equivalent stops the run (give
    --vkpath-via binary for it)."""

    # Command-line flags and the `[render]` key each sets (values as the scene format writes them).
    RENDER_KEYS = {"--splat": "splat", "--adaptive": "adaptive", "--light-sampling": "light_sampling",
                   "--sampler": "sampler", "--max-bounces": "max_bounces",
                   "--adaptive-threshold": "adaptive_threshold"}

    def __init__(self, label: str, extra_args: list[str], scene: Path):
        import vkpath

        self.label = label
        lenient, defines, render = False, {}, {}
        args = list(extra_args)
        while args:
            flag = args.pop(0)
            if flag == "--xml-lenient":
                lenient = True
            elif flag == "-D" and args:
                name, _, value = args.pop(0).partition("=")
                defines[name] = value
            elif flag in self.RENDER_KEYS and args:
                value = args.pop(0)
                if value in ("on", "off"):
                    value = value == "on"
                elif flag in ("--max-bounces", "--adaptive-threshold"):
                    value = float(value) if "." in value else int(value)
                render[self.RENDER_KEYS[flag]] = value
            else:
                sys.exit(f"compare.py: config {label!r}: the Python module has no equivalent of {flag!r}; "
                         "give --vkpath-via binary")
        self.scene = vkpath.load(scene, xml_lenient=lenient, **defines)
        if render:
            self.scene.set("render", **render)

    def render(self, spp: int, seed: int) -> Render:
        import numpy as np

        r = self.scene.render(spp=spp, seed=seed)
        if r.spp != spp:
            raise RuntimeError(f"vkpath rendered {r.spp} spp, asked for {spp}")
        return Render(np.asarray(r.image, dtype=np.float64), float(r.summary["seconds"]), spp, r.summary)


def vkpath_module_available() -> bool:
    try:
        import vkpath  # noqa: F401
    except ImportError:
        return False
    return True


MITSUBA = "Mitsuba 3"
MITSUBA_SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")


def is_mitsuba(label: str) -> bool:
    return label.startswith(MITSUBA)


class Mitsuba:
    def __init__(self, dr, mi, scene_dict: dict | None, sampler: str = "independent", scene=None):
        self.dr, self.mi, self.sampler = dr, mi, sampler
        # One label per sampler ("Mitsuba 3" alone is the independent sampler, as in earlier runs).
        self.label = MITSUBA if sampler == "independent" else f"{MITSUBA} {sampler}"
        self._counts: dict[int, int] = {}
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        # A scene dict (the TOML scenes, translated), or a scene Mitsuba loaded already (an XML file).
        self.scene = scene if scene is not None else mi.load_dict(scene_dict)
        t = time.perf_counter()
        self._render(1, seed=999_999)  # warm-up: kernel compilation (or Dr.Jit cache load), not timed
        self.warmup_seconds = time.perf_counter() - t

    def actual_spp(self, spp: int) -> int:
        """The samples per pixel Mitsuba's sampler really takes when asked for spp: stratified and
        ldsampler round up to a power of 4, orthogonal to the square of a prime, multijitter to a
        product of two near-equal factors."""
        if spp not in self._counts:
            self._counts[spp] = int(self.mi.load_dict({"type": self.sampler, "sample_count": spp}).sample_count())
        return self._counts[spp]

    def _render(self, spp: int, seed: int):
        import numpy as np

        img = self.mi.render(self.scene, spp=spp, seed=seed)
        self.dr.eval(img)
        self.dr.sync_thread()
        return np.array(img, dtype=np.float64)

    def _compiled(self) -> bool:
        """Did the calls since the last look compile a kernel (a miss in Dr.Jit's kernel cache)?"""
        return any(k.get("type") == self.dr.KernelType.JIT and not k.get("cache_hit", True)
                   for k in self.dr.kernel_history())

    def render(self, spp: int, seed: int) -> Render:
        # A render that had to compile a kernel (a new variant of the megakernel) is timed again: the
        # comparison leaves one-time JIT compilation out on both sides.
        for attempt in range(3):
            self._compiled()  # clears the history
            t = time.perf_counter()
            img = self._render(spp, seed)
            seconds = time.perf_counter() - t
            if not self._compiled():
                break
        return Render(img, seconds, self.actual_spp(spp), {"retimed": attempt})


# ---------------------------------------------------------------------------------------------------
# Statistics
# ---------------------------------------------------------------------------------------------------


@dataclass
class Reference:
    mean: object  # per-pixel mean of the batches
    var_of_mean: object  # per-pixel variance of that mean (from the spread of the batches)
    spp: int
    seconds: float
    # Per-pixel variance of the mean's channel sum: the channels of one path are correlated, so the
    # image mean's variance needs the covariances too, not just the per-channel variances.
    var_of_mean_sum: object = None


def reference_from_batches(batches: list[Render]) -> Reference:
    import numpy as np

    stack = np.stack([b.img for b in batches])
    k = len(batches)
    var = stack.var(axis=0, ddof=1) / k if k > 1 else np.zeros_like(stack[0])
    sums = stack.sum(axis=-1)
    var_sum = sums.var(axis=0, ddof=1) / k if k > 1 else np.zeros_like(sums[0])
    return Reference(stack.mean(axis=0), var, sum(b.spp for b in batches), sum(b.seconds for b in batches),
                     var_sum)


def unbiasedness(a: Reference, b: Reference, block: int = 16) -> dict:
    """Do the two renderers' references differ only by their noise?"""
    import numpy as np

    d = a.mean - b.mean
    v = a.var_of_mean + b.var_of_mean  # expected squared difference per pixel and channel
    ref_mean = 0.5 * (a.mean + b.mean).mean()
    n = d.size
    mean_diff = d.mean()
    mean_diff_se = math.sqrt((a.var_of_mean_sum + b.var_of_mean_sum).sum()) / n
    h, w, c = d.shape
    bh, bw = max(1, h // block), max(1, w // block)
    hh, ww = bh * block if h >= block else h, bw * block if w >= block else w
    sy, sx = (block, block) if h >= block and w >= block else (h, w)
    dz = d[:hh, :ww].reshape(hh // sy, sy, ww // sx, sx, c).sum(axis=(1, 3))
    vz = v[:hh, :ww].reshape(hh // sy, sy, ww // sx, sx, c).sum(axis=(1, 3))
    z = dz / np.sqrt(np.maximum(vz, 1e-300))
    return {
        "rel_rms_diff": math.sqrt((d * d).mean()) / ref_mean,
        "rel_rms_expected": math.sqrt(v.mean()) / ref_mean,
        "ms_ratio": float((d * d).mean() / max(v.mean(), 1e-300)),
        "rel_mean_diff": mean_diff / ref_mean,
        "mean_diff_z": mean_diff / mean_diff_se if mean_diff_se > 0 else float("nan"),
        "block_px": sy,
        "blocks": int(z.size),
        "max_block_abs_z": float(np.abs(z).max()),
        "blocks_over_4sigma": int((np.abs(z) > 4).sum()),
    }


def rel_errors(img, ref: Reference, ref_noise_ms: float) -> tuple[float, float]:
    """(raw, corrected): RMS difference over mean(ref); the corrected one has the reference's expected
    squared noise subtracted from the mean squared difference (img and ref are independent)."""
    import numpy as np

    ms_diff = float(((img - ref.mean) ** 2).mean())
    m = float(ref.mean.mean())
    return math.sqrt(ms_diff) / m, math.sqrt(max(ms_diff - ref_noise_ms, 0.0)) / m


def loglog_at(xs, ys, x):
    """Piecewise-linear interpolation of log y against log x (xs increasing)."""
    for xi, yi in zip(xs, ys):
        if xi == x:
            return yi
    lx = [math.log(v) for v in xs]
    ly = [math.log(v) for v in ys]
    t = math.log(x)
    for i in range(1, len(lx)):
        if lx[i - 1] <= t <= lx[i]:
            f = 0.0 if lx[i] == lx[i - 1] else (t - lx[i - 1]) / (lx[i] - lx[i - 1])
            return math.exp(ly[i - 1] + f * (ly[i] - ly[i - 1]))
    return None


def fitted_slope(points) -> float:
    """Least-squares slope of log(error) against log(spp) over the ladder's points from 4 spp on: the
    convergence rate, -0.5 for an unbiased Monte Carlo estimator of finite variance. points: (spp, error)."""
    pts = [p for p in points if p[0] >= 4 and p[1] > 0] or [p for p in points if p[1] > 0]
    if len(pts) < 2:
        return float("nan")
    lx = [math.log(p[0]) for p in pts]
    ly = [math.log(p[1]) for p in pts]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    sxx = sum((x - mx) ** 2 for x in lx)
    return sum((x - mx) * (y - my) for x, y in zip(lx, ly)) / sxx if sxx else float("nan")


def efficiency_constant(points) -> float | None:
    """c such that error ~ c / sqrt(seconds) (geometric mean of error * sqrt(seconds) over the ladder's
    last three renders, where fixed per-render costs matter least). Time to reach error e: (c / e)^2."""
    pts = [p for p in points if p[1] > 0][-3:]
    if not pts:
        return None
    return math.exp(sum(math.log(e * math.sqrt(t)) for t, e in pts) / len(pts))


def time_to(points, target: float) -> tuple[float | None, str]:
    """Seconds to reach `target` relative error, and how it was found: "" interpolated, "~" extrapolated,
    "<" already reached by the first render (its time is an upper bound). points: (seconds, error)
    in ladder order. Inside the measured range: piecewise-linear interpolation of log(error) against
    log(seconds), at the first crossing. Outside: error = c / sqrt(seconds), c from efficiency_constant
    (Monte Carlo's rate; the slope column shows how well the ladder follows it)."""
    pts = [p for p in points if p[1] > 0]
    if not pts:
        return None, "~"
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if (e0 - target) * (e1 - target) <= 0 and e0 != e1:
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), ""
    if target >= pts[0][1]:
        return pts[0][0], "<"
    c = efficiency_constant(pts)
    return (c / target) ** 2, "~"


# ---------------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------------


def default_scenes() -> list[Path]:
    d = ROOT / "scenes"
    names = sorted(glob.glob(str(d / "0*-*.toml"))) + sorted(glob.glob(str(d / "1*-*.toml")))
    names.append(str(d / "course.toml"))
    return [Path(n) for n in names]


def resolve_scene(s: str) -> Path:
    p = Path(s)
    if p.suffix in (".toml", ".xml") and p.exists():
        return p
    for cand in [ROOT / "scenes" / f"{s}.toml", *sorted((ROOT / "scenes").glob(f"{s}*.toml"))]:
        if cand.exists():
            return cand
    sys.exit(f"compare.py: no scene {s!r} (give a path or a name under scenes/, e.g. 06-glass or 06)")


def fmt_time(t, how: str) -> str:
    if t is None:
        return "n/a"
    s = f"{t:.3g} s" if t < 1000 else f"{t:.0f} s"
    return how + s


def parse_config(spec: str) -> tuple[str, list[str]]:
    label, _, args = spec.partition(":")
    return label.strip() or "vkpath", args.split()


def check_configs(configs: list[tuple[str, list[str]]]) -> None:
    """Each config is one ladder, one summary row and one column of the side-by-side tables, found by its
    label: labels must be distinct, and none may be Mitsuba's."""
    labels = [label for label, _ in configs]
    for label in labels:
        if labels.count(label) > 1:
            sys.exit(f"compare.py: two --vkpath-config share the label {label!r}; give each its own "
                     "(e.g. 'mis:--light-sampling mis' 'cone:--light-sampling cone')")
        if is_mitsuba(label):
            sys.exit(f"compare.py: the label {label!r} is taken for Mitsuba's ladders; choose another")
        if "|" in label:
            sys.exit(f"compare.py: a label may not contain '|' (it breaks the Markdown tables): {label!r}")


def file_label(label: str) -> str:
    """A label made safe for a file name."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in label)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", help="scene names (e.g. 06-glass, 06, course) or paths; "
                    "default: scenes/0*-*.toml scenes/1*-*.toml scenes/course.toml")
    ap.add_argument("--size", type=int, help="image width in pixels (height keeps the aspect); default 128")
    ap.add_argument("--max-spp", type=int, help="largest spp of the ladder (a power of 2); default 256")
    ap.add_argument("--time-budget", type=float, default=None,
                    help="stop a ladder early once one render of it took more than this many seconds")
    ap.add_argument("--ref-spp", type=int, help="reference spp PER RENDERER; default 1024")
    ap.add_argument("--ref-batches", type=int, help="independent batches per reference; default 16 (8 with --quick)")
    ap.add_argument("--rr-depth", type=int, default=3,
                    help="Russian roulette start for Mitsuba (vkpath's default roulette_depth is 3)")
    ap.add_argument("--vkpath", default=str(ROOT / "target" / "release" / "vkpath"), help="vkpath binary")
    ap.add_argument("--vkpath-via", choices=["module", "binary"], default=None,
                    help="render vkpath through its Python module (the default when `import vkpath` works: "
                         "setup.sh installs it) or by running the binary (--vkpath) for each render")
    ap.add_argument("--vkpath-config", action="append", metavar="LABEL:ARGS",
                    help="a vkpath setting to compare, e.g. 'vkpath generic:--generic' or "
                    "'mis:--light-sampling mis' (repeatable: one ladder each, side by side in the tables; "
                    "the first also renders the reference); default 'vkpath:' (no extra flags)")
    ap.add_argument("--mitsuba-samplers", nargs="+", default=list(MITSUBA_SAMPLERS), metavar="SAMPLER",
                    help="Mitsuba samplers to run a ladder with (one each; the tables compare vkpath with the "
                    "best of them per scene); default: " + " ".join(MITSUBA_SAMPLERS) + ". The reference is "
                    "always rendered with the independent sampler")
    ap.add_argument("--check-every-config", action="store_true",
                    help="render the reference batches with every --vkpath-config (not only the first) and "
                    "check each against Mitsuba's (the unbiasedness table gets a row per config); costs "
                    "--ref-spp more samples per extra config and scene")
    ap.add_argument("--xml-filter", choices=["box", "file"], default="box",
                    help="Mitsuba XML scenes: a one-pixel box filter on both sides (default), or the file's own "
                         "(Mitsuba splats it over several pixels, vkpath samples it; see mitsuba_xml.py)")
    ap.add_argument("--seed-base", type=int, default=0,
                    help="added to every seed, for an independent repetition of a run")
    ap.add_argument("--repeat", type=int, default=1,
                    help="time each ladder render this many times and keep the fastest (noisy machines)")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: 64x64, ladder to 64 spp, reference 256 spp in 8 batches")
    ap.add_argument("--tag", help="output file prefix; default 'peers' ('quick' with --quick)")
    ap.add_argument("--out", default=str(HERE / "results"), help="output folder")
    ap.add_argument("--report", action="store_true",
                    help="render nothing: rebuild <tag>-summary.csv and <tag>.md from the saved ladder")
    a = ap.parse_args()
    if a.report:
        return report(Path(a.out), a.tag or ("quick" if a.quick else "peers"))

    size = a.size or (64 if a.quick else 128)
    max_spp = a.max_spp or (64 if a.quick else 256)
    ref_spp = a.ref_spp or (256 if a.quick else 1024)
    batches = a.ref_batches or (8 if a.quick else 16)
    tag = a.tag or ("quick" if a.quick else "peers")
    if ref_spp % batches:
        sys.exit("compare.py: --ref-spp must be a multiple of --ref-batches")
    configs = [parse_config(c) for c in (a.vkpath_config or ["vkpath:"])]
    check_configs(configs)
    for sampler in a.mitsuba_samplers:
        if sampler not in MITSUBA_SAMPLERS:
            sys.exit(f"compare.py: unknown Mitsuba sampler {sampler!r} (one of {', '.join(MITSUBA_SAMPLERS)})")
    if len(set(a.mitsuba_samplers)) != len(a.mitsuba_samplers):
        sys.exit("compare.py: a Mitsuba sampler is named twice in --mitsuba-samplers")
    vkpath_bin = Path(a.vkpath)
    via = a.vkpath_via or ("module" if vkpath_module_available() else "binary")
    if via == "module" and not vkpath_module_available():
        sys.exit("compare.py: --vkpath-via module, and `import vkpath` fails: run benches/peers/setup.sh "
                 "(it installs the module from this checkout into the venv)")
    if via == "binary" and not vkpath_bin.exists():
        sys.exit(f"compare.py: no vkpath binary at {vkpath_bin}; run `cargo build --release` first")

    import numpy as np

    dr, mi, llvm = import_mitsuba()
    mi.set_log_level(mi.LogLevel.Error)  # the samplers' "sample count rounded" warnings: actual_spp
    out = Path(a.out)
    tmp = out / "tmp"
    imgdir = out / "images" / tag
    for d in (out, tmp, imgdir):
        d.mkdir(parents=True, exist_ok=True)

    scenes = [resolve_scene(s) for s in a.scenes] if a.scenes else default_scenes()
    spps = [1 << i for i in range(int(math.log2(max_spp)) + 1)]

    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    cpu = platform.processor() or ""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    meta = {
        "date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpu": f"{cpu} x {os.cpu_count()} logical",
        "vkpath_commit": commit + (" (+ uncommitted changes)" if dirty else ""),
        "mitsuba": f"{mi.__version__} llvm_ad_rgb, drjit {dr.__version__}, "
                   f"LLVM {Path(llvm).name}",
        "size": f"{size} wide (box filter{'' if a.xml_filter == 'box' else '; XML scenes: the file filter'})",
        "ladder": f"1..{max_spp} spp (doubling)",
        "reference": f"{ref_spp} spp from each renderer in {batches} batches (mean of both)",
        "mitsuba_samplers": " ".join(a.mitsuba_samplers),
        # The module is the one setup.sh installed: run setup.sh again after changing vkpath's code.
        "vkpath_via": "Python module" if via == "module" else f"binary {vkpath_bin}",
    }
    print("# " + ", ".join(f"{k}: {v}" for k, v in meta.items()), flush=True)

    ladder_rows, ref_rows, skipped = [], [], []
    vk_device = None
    seen: dict[str, str] = {}
    aliases: dict[str, list[str]] = {}
    for scene_path in scenes:
        if scene_path.suffix == ".xml":
            # A Mitsuba scene file, read by each renderer's own importer (mitsuba_xml.py): its filter,
            # max_depth and everything else as the file says; only the size, the sampler and rr_depth are
            # the comparison's. Bitterli's exports are all called scene.xml: their folder names them.
            name = scene_path.parent.name if scene_path.stem == "scene" else scene_path.stem
            fw, fh = mx.film_size(scene_path)
            w = size
            h = max(1, round(size * fh / fw))
            depth = mx.max_depth(scene_path)
            aliases[name] = []
            print(f"## {name}: {w}x{h}, Mitsuba XML, max_depth {depth}, rr_depth {a.rr_depth}, filter "
                  f"{a.xml_filter}", flush=True)
            box = a.xml_filter == "box"
            # vkpath reads Mitsuba's stratified samplers as its Sobol' sampler, its default (the TOML scenes'
            # too): each renderer with its own best sampler.
            vk_scene = mx.copy(scene_path, tmp / name / "vkpath.xml", w, h, "multijitter", a.rr_depth, box)
            vk_args = []

            def mitsuba_for(sampler: str, scene_path=scene_path, name=name, w=w, h=h, box=box) -> Mitsuba:
                c = mx.copy(scene_path, tmp / name / f"{sampler}.xml", w, h, sampler, a.rr_depth, box)
                return Mitsuba(dr, mi, None, sampler, scene=mi.load_file(str(c)))
        else:
            name = scene_path.stem
            raw = ms.load_toml(scene_path)
            reasons = ms.unsupported_reasons(raw)
            if reasons:
                skipped.append((name, "; ".join(reasons)))
                print(f"## {name}: skipped: {'; '.join(reasons)}", flush=True)
                continue
            r = ms.resolved(raw)
            w = size
            h = max(1, round(size * r["image"]["height"] / r["image"]["width"]))
            over = ms.with_overrides(raw, scene_path.parent, filter="box", width=w, height=h)
            # Several course steps differ only in what the comparison overrides (filter, samples, seed) or
            # in the display transform (gamma, exposure): render each distinct scene once.
            key = ms.render_key(over)
            if key in seen:
                aliases[seen[key]].append(name)
                print(f"## {name}: the same scene as {seen[key]} once the filter is box; not rendered again",
                      flush=True)
                continue
            seen[key] = name
            aliases[name] = []
            vk_scene = tmp / f"{name}.toml"
            vk_scene.write_text(ms.dump_toml(over))
            vk_args = []
            max_bounces = ms.resolved(over)["render"]["max_bounces"]
            print(f"## {name}: {w}x{h}, max_bounces {max_bounces} (Mitsuba max_depth {max_bounces + 1}, "
                  f"rr_depth {a.rr_depth})", flush=True)

            def mitsuba_for(sampler: str, over=over, name=name) -> Mitsuba:
                return Mitsuba(dr, mi, ms.mitsuba_dict(mi, over, spp=1, tmp_dir=tmp / name,
                                                       rr_depth=a.rr_depth, sampler=sampler), sampler)

        if via == "module":
            vks = [VkpathModule(label, [*vk_args, *extra], vk_scene) for label, extra in configs]
        else:
            vks = [Vkpath(vkpath_bin, label, [*vk_args, *extra], vk_scene, tmp) for label, extra in configs]
        for v in vks:
            v.render(1, seed=999_999)  # warm-up (page cache, driver), not recorded
        # No `samples_per_pass`: Mitsuba 3.6 deprecates it and splits a large render into passes itself.
        # The reference batches use the independent sampler (its batches are independent estimates); the
        # ladders every sampler asked for.
        mits = {sampler: mitsuba_for(sampler) for sampler in dict.fromkeys(["independent", *a.mitsuba_samplers])}
        mit = mits["independent"]

        # 1. The common reference and the unbiasedness check. Batches alternate between the renderers
        # so that a change of load on the machine hits both alike.
        # With --check-every-config each vkpath config renders reference batches too and is checked against
        # Mitsuba on its own; the common reference stays the first config's and Mitsuba's.
        per = ref_spp // batches
        checked = vks if a.check_every_config else vks[:1]
        vk_batches: dict[str, list] = {v.label: [] for v in checked}
        mi_batches = []
        for k in range(batches):
            for v in checked:
                vk_batches[v.label].append(v.render(per, seed=a.seed_base + 1 + k))
            mi_batches.append(mit.render(per, seed=a.seed_base + 1 + k))
        refs_vk = {label: reference_from_batches(b) for label, b in vk_batches.items()}
        ref_vk = refs_vk[vks[0].label]
        ref_mi = reference_from_batches(mi_batches)
        ref = Reference(0.5 * (ref_vk.mean + ref_mi.mean), 0.25 * (ref_vk.var_of_mean + ref_mi.var_of_mean),
                        ref_vk.spp + ref_mi.spp, ref_vk.seconds + ref_mi.seconds)
        ref_noise_ms = float(ref.var_of_mean.mean())
        ref_noise_rel = math.sqrt(ref_noise_ms) / float(ref.mean.mean())
        write_exr(imgdir / f"{name}-ref.exr", ref.mean)
        write_exr(imgdir / f"{name}-ref-mitsuba.exr", ref_mi.mean)
        print(f"   reference: {ref_vk.spp}+{ref_mi.spp} spp, noise {100 * ref_noise_rel:.2f}%", flush=True)
        for i, (label, rv) in enumerate(refs_vk.items()):
            check = unbiasedness(rv, ref_mi)
            suffix = "" if i == 0 else "-" + file_label(label)
            write_exr(imgdir / f"{name}-ref-vkpath{suffix}.exr", rv.mean)
            ref_rows.append({
                "scene": name, "vkpath_config": label, "width": w, "height": h, "spp_each": ref_spp,
                "batches": batches,
                "vkpath_seconds": round(rv.seconds, 3), "mitsuba_seconds": round(ref_mi.seconds, 3),
                "ref_rel_noise": f"{ref_noise_rel:.5f}",
                **{k: (f"{v:.5g}" if isinstance(v, float) else v) for k, v in check.items()},
            })
            print(f"   {label} vs Mitsuba: rms diff {100 * check['rel_rms_diff']:.2f}% (expected "
                  f"{100 * check['rel_rms_expected']:.2f}% from noise, ratio of squares "
                  f"{check['ms_ratio']:.3f}), mean diff {100 * check['rel_mean_diff']:+.3f}% "
                  f"(z = {check['mean_diff_z']:+.2f}), max |z| of {check['blocks']} blocks "
                  f"{check['max_block_abs_z']:.2f}", flush=True)

        # 2. The ladders, interleaved: at each spp every renderer renders once (the order rotating from
        # one step to the next), so that load from elsewhere on the machine falls on all of them alike.
        # With --repeat N, each render is timed N times and the fastest counts (the image is the first).
        renderers = [(v.label, v) for v in vks] + [(mits[sm].label, mits[sm]) for sm in a.mitsuba_samplers]
        ladders: dict[str, list] = {label: [] for label, _ in renderers}
        active = {label for label, _ in renderers}
        for i, spp in enumerate(spps):
            order = renderers[i % len(renderers):] + renderers[:i % len(renderers)]
            for label, rdr in order:
                if label not in active:
                    continue
                # A Mitsuba sampler that rounds this spp to the count of its previous step skips it.
                if isinstance(rdr, Mitsuba) and ladders[label] and rdr.actual_spp(spp) == ladders[label][-1][2]:
                    continue
                res = rdr.render(spp, seed=a.seed_base + 1000 + i)
                spp_done = res.spp
                seconds = res.seconds
                for _ in range(a.repeat - 1):
                    seconds = min(seconds, rdr.render(spp, seed=a.seed_base + 1000 + i).seconds)
                raw_e, e = rel_errors(res.img, ref, ref_noise_ms)
                sps = w * h * spp_done / seconds
                if isinstance(rdr, Vkpath) and vk_device is None:
                    vk_device = res.info.get("device")
                ladder_rows.append({
                    "scene": name, "renderer": label, "spp": spp_done, "seconds": f"{seconds:.5f}",
                    "samples_per_s": f"{sps:.0f}", "rel_error": f"{e:.5f}", "rel_error_raw": f"{raw_e:.5f}",
                })
                ladders[label].append((seconds, e, spp_done, sps))
                if a.time_budget is not None and seconds > a.time_budget:
                    active.discard(label)
        for label, pts in ladders.items():
            print(f"   {label:>12}: " + "  ".join(f"{p[2]}spp {p[0]:.2f}s {100 * p[1]:.1f}%" for p in pts),
                  flush=True)

    meta["vkpath_device"] = vk_device or "?"
    meta["vkpath_driver"] = vkpath_driver(vkpath_bin) if vkpath_bin.exists() else ""
    meta["command"] = " ".join(["compare.py", *sys.argv[1:]])
    for rows in (ladder_rows, ref_rows):
        for row in rows:
            row["same_as"] = " ".join(aliases.get(row["scene"]) or [])
    write_csv(out / f"{tag}-ladder.csv", ladder_rows)
    write_csv(out / f"{tag}-reference.csv", ref_rows)
    (out / f"{tag}-meta.json").write_text(json.dumps({"meta": meta, "skipped": skipped}, indent=1) + "\n")
    return report(out, tag)


def vkpath_driver(binary: Path) -> str:
    """The chosen device's driver as `vkpath info --json` reports it (e.g. "llvmpipe: Mesa 25.0.7 (LLVM
    15.0.6)"): the Mesa version changes lavapipe's speed."""
    p = subprocess.run([str(binary), "info", "--json"], capture_output=True, text=True)
    try:
        info = json.loads(p.stdout)
        return info["devices"][info["chosen"]].get("driver", "")
    except (ValueError, KeyError, IndexError, TypeError):
        return ""


def write_csv(path, rows):
    if not rows:
        return
    with open(path, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        wr.writeheader()
        wr.writerows(rows)


def read_csv(path) -> list[dict]:
    if not Path(path).exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fit_time_model(points) -> tuple[float, float]:
    """(a, b) of seconds = a + b spp, fitted to a ladder's (spp, seconds) by least squares on the RELATIVE
    residuals (each render weighs alike whatever its length), over the renders of at least 1/16 of the
    ladder's top spp (the shortest renders are all timer jitter); a >= 0."""
    top = max(s for s, _ in points)
    pts = [(s, t) for s, t in points if s * 16 >= top and t > 0] or [(s, t) for s, t in points if t > 0]
    w = [1.0 / (t * t) for _, t in pts]
    sw = sum(w)
    ss = sum(wi * s for wi, (s, _) in zip(w, pts))
    st = sum(wi * t for wi, (_, t) in zip(w, pts))
    sss = sum(wi * s * s for wi, (s, _) in zip(w, pts))
    sst = sum(wi * s * t for wi, (s, t) in zip(w, pts))
    det = sw * sss - ss * ss
    if len(pts) >= 2 and det > 0:
        a = (sss * st - ss * sst) / det
        b = (sw * sst - ss * st) / det
        if a >= 0 and b > 0:
            return a, b
    return 0.0, sst / sss  # through the origin


def summarize(ladder_rows: list[dict]) -> list[dict]:
    """Per scene and renderer, from the ladder: samples/s, times to the TARGETS, error at equal time."""
    scenes: dict[str, dict[str, list]] = {}
    same_as: dict[str, str] = {}
    for r in ladder_rows:
        pts = scenes.setdefault(r["scene"], {}).setdefault(r["renderer"], [])
        pts.append((float(r["seconds"]), float(r["rel_error"]), int(r["spp"]), float(r["samples_per_s"])))
        same_as[r["scene"]] = r.get("same_as", "")
    rows = []
    for name, ladders in scenes.items():
        # Render time is affine in spp (a fixed cost per render plus a cost per sample); on a shared
        # machine single renders take spikes of load. Each ladder's times are therefore replaced by the
        # fitted model seconds = a + b spp (fit_time_model), which is monotone and uses every render;
        # the measured seconds stay in the ladder CSV.
        models = {label: fit_time_model([(p[2], p[0]) for p in pts]) for label, pts in ladders.items()}
        modelled = {label: [models[label][0] + models[label][1] * p[2] for p in pts]
                    for label, pts in ladders.items()}
        # Equal time: the longest time that every renderer's ladder reached on this scene.
        t_eq = min(times[-1] for times in modelled.values())
        for label, pts in ladders.items():
            good = [(t, p[1]) for t, p in zip(modelled[label], pts) if p[1] > 0]
            a_fixed, b_per_spp = models[label]
            pixels = pts[-1][3] * pts[-1][0] / pts[-1][2]  # samples/s x seconds / spp
            slope = fitted_slope([(spp, e) for _, e, spp, _ in pts])
            c = efficiency_constant(good)
            # Noise per sample, independent of speed: error x sqrt(spp) (geometric mean over the renders
            # of 32 spp or more, or the last three).
            top = [p for p in pts if p[2] >= 32 and p[1] > 0] or [p for p in pts if p[1] > 0][-3:]
            per_sample = math.exp(sum(math.log(p[1] * math.sqrt(p[2])) for p in top) / len(top)) if top else None
            row = {"scene": name, "renderer": label,
                   "samples_per_s": f"{pixels / b_per_spp:.0f}",
                   "samples_per_s_largest_render": f"{pts[-1][3]:.0f}",
                   "fixed_seconds_per_render": f"{a_fixed:.4f}",
                   "error_x_sqrt_spp": "" if per_sample is None else f"{per_sample:.4f}",
                   "max_spp": pts[-1][2], "max_seconds": f"{pts[-1][0]:.3f}",
                   "max_seconds_modelled": f"{modelled[label][-1]:.3f}",
                   "error_at_max": f"{pts[-1][1]:.5f}", "slope_vs_spp": f"{slope:.3f}",
                   "efficiency_c": "" if c is None else f"{c:.5f}"}
            for target in TARGETS:
                t, how = time_to(good, target)
                row[f"t_{round(100 * target)}pct"] = "" if t is None else f"{t:.4g}"
                row[f"t_{round(100 * target)}pct_how"] = how
            e_eq = loglog_at([p[0] for p in good], [p[1] for p in good], t_eq) if good else None
            row["equal_time_s"] = f"{t_eq:.3f}"
            row["error_at_equal_time"] = "" if e_eq is None else f"{e_eq:.5f}"
            row["same_as"] = same_as[name]
            rows.append(row)
    return rows


def side_by_side(summary_rows: list[dict], shown) -> list[str]:
    """Markdown: one row per scene, one column per renderer (every vkpath config in the order given, then
    Mitsuba 3), for the error at the scene's equal time and for the noise per sample (error x sqrt(spp)).
    The lowest error of each row is in bold."""
    renderers: list[str] = []
    by_scene: dict[str, dict[str, dict]] = {}
    for row in summary_rows:
        if row["renderer"] not in renderers:
            renderers.append(row["renderer"])
        by_scene.setdefault(row["scene"], {})[row["renderer"]] = row
    # Mitsuba last, the vkpath configs in the order of the command line (the ladder CSV's order).
    renderers = [r for r in renderers if not is_mitsuba(r)] + [r for r in renderers if is_mitsuba(r)]
    md: list[str] = []
    for title, key, fmt in (
        ("Relative error at equal time (the longest time every renderer's ladder reached on the scene)",
         "error_at_equal_time", lambda v: f"{100 * v:.2f}%"),
        ("Noise per sample, error x sqrt(spp) (speed left out)", "error_x_sqrt_spp", lambda v: f"{v:.4f}"),
    ):
        md += ["", title + ":", "",
               "| scene | " + ("equal time | " if key == "error_at_equal_time" else "")
               + " | ".join(renderers) + " |",
               "| --- | " + ("---: | " if key == "error_at_equal_time" else "")
               + " | ".join("---:" for _ in renderers) + " |"]
        for rows in by_scene.values():
            values = {r: float(rows[r][key]) for r in renderers if r in rows and rows[r].get(key)}
            best = min(values.values()) if values else None
            cells = []
            for r in renderers:
                if r not in values:
                    cells.append("n/a")
                else:
                    text = fmt(values[r])
                    cells.append(f"**{text}**" if values[r] == best and len(values) > 1 else text)
            first = next(iter(rows.values()))
            lead = [shown(first)]
            if key == "error_at_equal_time":
                lead.append(f"{float(first['equal_time_s']):.2f} s")
            md.append("| " + " | ".join(lead + cells) + " |")
    return md


def efficiency_table(summary_rows: list[dict], shown) -> list[str]:
    """Markdown: the headline comparison. Equal-time efficiency is 1 / (error^2 x seconds) = 1 / c^2 with
    c = error x sqrt(seconds) (efficiency_constant: the ladder's last three renders), so the ratio of two
    renderers' efficiencies is (c_other / c_this)^2: how many times longer the other needs for the same
    error. Each vkpath config against the best Mitsuba sampler of each scene (the lowest c), and against
    Mitsuba's independent sampler; then the median and the minimum over the distinct scenes."""
    by_scene: dict[str, dict[str, dict]] = {}
    for row in summary_rows:
        by_scene.setdefault(row["scene"], {})[row["renderer"]] = row
    configs: list[str] = []
    for row in summary_rows:
        if not is_mitsuba(row["renderer"]) and row["renderer"] not in configs:
            configs.append(row["renderer"])
    md = ["", "Equal-time efficiency, 1 / (error^2 x seconds), of vkpath against Mitsuba 3's best sampler on "
          "each scene (ratio > 1: vkpath reaches the same error sooner, by that factor):", "",
          "| scene | vkpath config | vkpath samples/s | Mitsuba's best sampler | its samples/s | "
          "vkpath / best Mitsuba | vkpath / Mitsuba independent |",
          "| --- | --- | ---: | --- | ---: | ---: | ---: |"]
    ratios: dict[str, list[tuple[float, str]]] = {c: [] for c in configs}
    for rows in by_scene.values():
        mits = {r: row for r, row in rows.items() if is_mitsuba(r) and row.get("efficiency_c")}
        if not mits:
            continue
        best = min(mits, key=lambda r: float(mits[r]["efficiency_c"]))
        c_best = float(mits[best]["efficiency_c"])
        indep = mits.get(MITSUBA)
        for config in configs:
            row = rows.get(config)
            if row is None or not row.get("efficiency_c"):
                continue
            c = float(row["efficiency_c"])
            ratio = (c_best / c) ** 2
            ratios[config].append((ratio, row["scene"]))
            vs_indep = f"{(float(indep['efficiency_c']) / c) ** 2:.2f}" if indep else "n/a"
            sampler = best[len(MITSUBA):].strip() or "independent"
            md.append(f"| {shown(row)} | {config} | {float(row['samples_per_s']) / 1e6:.2f} M | {sampler} | "
                      f"{float(mits[best]['samples_per_s']) / 1e6:.2f} M | {ratio:.2f} | {vs_indep} |")
    md.append("")
    for config, rs in ratios.items():
        if not rs:
            continue
        values = sorted(r for r, _ in rs)
        n = len(values)
        median = values[n // 2] if n % 2 else 0.5 * (values[n // 2 - 1] + values[n // 2])
        low, low_scene = min(rs)
        md.append(f"- {config}: median {median:.2f} over {n} distinct scenes, minimum {low:.2f} ({low_scene}) "
                  f"(targets: median >= 2, minimum >= 1)")
    return md


def report(out: Path, tag: str) -> int:
    """Summary CSV and Markdown tables from <tag>-ladder.csv, <tag>-reference.csv and <tag>-meta.json."""
    ladder_rows = read_csv(out / f"{tag}-ladder.csv")
    ref_rows = read_csv(out / f"{tag}-reference.csv")
    info = json.loads((out / f"{tag}-meta.json").read_text())
    meta, skipped = info["meta"], info["skipped"]
    summary_rows = summarize(ladder_rows)
    write_csv(out / f"{tag}-summary.csv", summary_rows)

    def shown(row) -> str:
        same = row.get("same_as", "").split()
        return row["scene"] + (f" (= {', '.join(same)})" if same else "")

    samplers = meta.get("mitsuba_samplers")
    md = [f"Measured {meta['date_utc']} on {meta['cpu']}; vkpath {meta['vkpath_commit']} on "
          f"{meta['vkpath_device']}{' (' + meta['vkpath_driver'] + ')' if meta.get('vkpath_driver') else ''}; "
          f"Mitsuba {meta['mitsuba']}{' (samplers: ' + samplers + ')' if samplers else ''}. {meta['size']}, "
          f"ladder {meta['ladder']}, reference {meta['reference']}. Command: `{meta['command']}`.", "",
          "| scene | renderer | samples/s | error x sqrt(spp) | time to 5% | time to 2% | time to 1% | "
          "error at equal time | error ~ spp^ |",
          "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for row in summary_rows:
        cells = [shown(row), row["renderer"], f"{float(row['samples_per_s']) / 1e6:.2f} M",
                 row["error_x_sqrt_spp"]]
        for target in TARGETS:
            k = f"t_{round(100 * target)}pct"
            cells.append(fmt_time(float(row[k]) if row[k] else None, row[k + "_how"]))
        e = row["error_at_equal_time"]
        cells.append(f"{100 * float(e):.2f}% @ {float(row['equal_time_s']):.2f} s" if e else "n/a")
        cells.append(row["slope_vs_spp"])
        md.append("| " + " | ".join(cells) + " |")
    md += ["", "~ : beyond the ladder, extrapolated as error = c / sqrt(time) from its last three renders; "
           "< : reached by the ladder's first render (an upper bound). Times and samples/s come from "
           "each ladder's fitted time model seconds = a + b spp (measured seconds: the ladder CSV). "
           "error x sqrt(spp): the noise per sample, whatever the speed (lower is better). Last "
           "column: the fitted convergence rate (-0.5 expected)."]
    md += efficiency_table(summary_rows, shown)
    md += side_by_side(summary_rows, shown)
    with_config = any(r.get("vkpath_config") for r in ref_rows)
    md += ["", "Unbiasedness (vkpath's reference against Mitsuba's; expected: ratio ~1, |z| small):", "",
           "| scene | " + ("vkpath config | " if with_config else "")
           + "ref spp each | ref noise | rms diff | expected from noise | ratio of squares | mean diff (z) | "
           "max block abs z (blocks, over 4) |",
           "| --- | " + ("--- | " if with_config else "")
           + "---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in ref_rows:
        config = f"{r.get('vkpath_config', '')} | " if with_config else ""
        md.append(f"| {shown(r)} | {config}{r['spp_each']} | {100 * float(r['ref_rel_noise']):.2f}% | "
                  f"{100 * float(r['rel_rms_diff']):.2f}% | {100 * float(r['rel_rms_expected']):.2f}% | "
                  f"{float(r['ms_ratio']):.3f} | {100 * float(r['rel_mean_diff']):+.3f}% "
                  f"({float(r['mean_diff_z']):+.2f}) | {float(r['max_block_abs_z']):.2f} "
                  f"({r['blocks']}, {r['blocks_over_4sigma']}) |")
    if skipped:
        md += ["", "Skipped:"] + [f"- {n}: {why}" for n, why in skipped]
    text = "\n".join(md) + "\n"
    (out / f"{tag}.md").write_text(text)
    print()
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
