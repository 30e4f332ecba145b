#!/usr/bin/env python3
"""How long a user waits for the first sample of a scene: the wall time of `vkpath render SCENE --width 32
--height 32 --spp 1` started with an empty Mesa shader cache (cold: lavapipe compiles the kernel), and the
same command again on the cache it filled (warm: loading the scene, building its BVH, uploading it and one
sample). Cold minus warm is the kernel's compile. Each scene gets its own fresh cache directory
(MESA_SHADER_CACHE_DIR), so nothing one scene compiled helps another.

    benches/cold_start.py --binary target/release/vkpath scenes/*.toml \
        ../shared/real-scenes/bitterli-*/scene.xml ... [--generic scenes/course.toml] \
        [--out benches/results/cold-start-YYYY-MM-DD.md]

Mitsuba XML files are read with `--xml-lenient -D integrator=path` (Bitterli's files name integrators
vkpath does not have). `--generic SCENE` adds the generic kernel's row (`vkpath render --generic`, every
feature: minutes on lavapipe). Prints a Markdown table (and writes it to --out), with the date, the
binary's version and the Vulkan driver.
"""

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time


def render_once(binary, scene, cache, extra):
    """One 32x32 1-spp render with the given cache directory: (seconds, error text or None)."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [binary, "render", scene, "--width", "32", "--height", "32", "--spp", "1",
               "-o", os.path.join(out, "image.png")] + extra
        if scene.endswith(".xml"):
            cmd += ["--xml-lenient"]
            with open(scene, encoding="utf-8") as f:
                if "$integrator" in f.read():  # a -D the file does not use is an error
                    cmd += ["-D", "integrator=path"]
        env = dict(os.environ, MESA_SHADER_CACHE_DIR=cache)
        env.pop("MESA_SHADER_CACHE_DISABLE", None)
        start = time.monotonic()
        done = subprocess.run(cmd, capture_output=True, text=True, env=env)
        seconds = time.monotonic() - start
        return seconds, (done.stderr.strip() if done.returncode != 0 else None)


def measure(binary, scene, extra):
    with tempfile.TemporaryDirectory() as cache:
        cold, err = render_once(binary, scene, cache, extra)
        if err:
            sys.exit(f"{scene}: {err}")
        warm, err = render_once(binary, scene, cache, extra)
        if err:
            sys.exit(f"{scene}: {err}")
    return cold, warm


def label(scene):
    parent = os.path.basename(os.path.dirname(os.path.abspath(scene)))
    name = os.path.basename(scene)
    return name if parent == "scenes" else f"{parent}/{name}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", default="target/release/vkpath")
    ap.add_argument("--generic", metavar="SCENE", help="also time the generic kernel on this scene")
    ap.add_argument("--out", help="write the Markdown table here too")
    ap.add_argument("scenes", nargs="+")
    args = ap.parse_args()

    info = json.loads(subprocess.run([args.binary, "info", "--json"], capture_output=True, text=True,
                                     check=True).stdout)
    driver = info["devices"][info["chosen"]]["driver"]
    version = subprocess.run([args.binary, "--version"], capture_output=True, text=True).stdout.strip()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    if commit.returncode == 0:
        version += f" (checkout at {commit.stdout.strip()})"

    rows = []
    for scene in args.scenes:
        cold, warm = measure(args.binary, scene, [])
        rows.append((label(scene), "specialised", cold, warm))
        print(f"{rows[-1][0]}: cold {cold:.2f} s, warm {warm:.2f} s", file=sys.stderr)
    if args.generic:
        cold, warm = measure(args.binary, args.generic, ["--generic"])
        rows.append((label(args.generic), "generic", cold, warm))

    lines = [
        f"Cold-cache first sample, {datetime.date.today().isoformat()}, {version}, {driver}, "
        f"{os.cpu_count()} CPUs.",
        "",
        f"`{' '.join(sys.argv)}`",
        "",
        "| scene | kernel | cold (s) | warm (s) | compile = cold - warm (s) |",
        "| --- | --- | ---: | ---: | ---: |",
    ]
    for name, kernel, cold, warm in rows:
        lines.append(f"| {name} | {kernel} | {cold:.2f} | {warm:.2f} | {cold - warm:.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
