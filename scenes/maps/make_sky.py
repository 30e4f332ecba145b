#!/usr/bin/env python3
"""Writes scenes/maps/sky.exr: a small equirectangular sky in linear radiance (W sr^-1 m^-2), for
scenes/envmap.toml.

Run from the repository root, with the Python environment of the Mitsuba comparison (numpy and OpenEXR;
benches/peers/setup.sh creates it):

    benches/peers/.venv/bin/python scenes/maps/make_sky.py            # writes scenes/maps/sky.exr
    benches/peers/.venv/bin/python scenes/maps/make_sky.py -o X.exr   # elsewhere

The output is deterministic (no random numbers), so re-running it reproduces the committed file.

The map (256 x 128 texels, RGB float32, ZIP-compressed) follows Mitsuba 3's `envmap` conventions, which
vkpath's [environment] map shares (benches/peers/mitsuba_scene.py states and checks them): the image's top
row looks up (+y) and its bottom row down; a direction d in the map's frame has the azimuth
phi = atan2(d.x, -d.z) and u = phi / (2 pi), so the left and right edges look along -z, a quarter of the
way across along +x, the middle column along +z, three quarters along -x. Texel (i, j) of a W x H map is
looked up at u = (i + 1/2) / W and v = j / (H - 1), with v = theta / pi the angle from +y (Mitsuba puts the
first and last rows on the poles); each texel here holds the sky's value in exactly that direction.

What is in it:
* sky: above the horizon, a gradient from a pale, bright blue at the horizon to a deeper blue at the
  zenith (radiance about 0.9 at the horizon, 0.35 at the zenith);
* ground: below the horizon, a uniform dark brown (radiance about 0.1), blended into the sky over the
  2 degrees around the horizon so that no texel row jumps;
* sun: a disc of 6 degrees angular diameter (the real sun is 0.53: this one is wider so that a few texels
  of a small map carry it), radiance about 1500 with a soft edge over its outer degree and a faint halo around
  it, at elevation 35 degrees and map azimuth 270 degrees (u = 3/4: the map's -x). With
  [environment] rotate = 30 (scenes/envmap.toml) it lights the scene from azimuth 270 - 30 = 240 degrees,
  the world direction (-0.87, 0, 0.5) in the horizontal plane: from the left and behind a camera that
  looks along -z; with rotate = 0 it would come from straight left (-x). So a rotation shows as turning
  shadows.
The script prints the irradiance the sun and the sky each give a horizontal surface (the sun's dominates,
so shadows are distinct).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 256, 128

SUN_ELEVATION_DEG = 35.0
SUN_AZIMUTH_DEG = 270.0  # phi = atan2(x, -z) in the map's frame: 270 = the map's -x
SUN_DIAMETER_DEG = 6.0
SUN_EDGE_DEG = 1.0  # the disc's radiance falls from full to 0 over its outer degree
SUN_RADIANCE = np.array([1500.0, 1420.0, 1280.0])  # warm white
HALO = np.array([1.5, 1.3, 1.0])  # halo radiance next to the disc, falling off over ~8 degrees
HORIZON = np.array([0.85, 0.92, 1.00])
ZENITH = np.array([0.20, 0.35, 0.80])
GROUND = np.array([0.11, 0.09, 0.07])
HORIZON_BLEND_DEG = 2.0


def smoothstep(e0: float, e1: float, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def directions(width: int, height: int):
    """Unit direction of every texel (Mitsuba's lookup points), shape (H, W, 3), and the solid angle each
    texel stands for (for the irradiance printout: rows on the poles get half a row's height)."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / (height - 1)
    phi = 2.0 * math.pi * u[None, :]
    theta = math.pi * v[:, None]
    d = np.stack(np.broadcast_arrays(np.sin(phi) * np.sin(theta), np.cos(theta) + 0.0 * phi,
                                     -np.cos(phi) * np.sin(theta)), axis=-1)
    row_height = np.full(height, math.pi / (height - 1))
    row_height[[0, -1]] *= 0.5
    d_omega = (2.0 * math.pi / width) * row_height[:, None] * np.abs(np.sin(theta)) + 0.0 * phi
    return d, d_omega


def sky(width: int = WIDTH, height: int = HEIGHT) -> tuple[np.ndarray, dict]:
    d, d_omega = directions(width, height)
    elevation = np.degrees(np.arcsin(np.clip(d[..., 1], -1.0, 1.0)))  # degrees above the horizon

    # Sky: horizon colour to zenith colour with the square root of sin(elevation) (a quick brightening
    # towards the horizon); ground below; a smooth blend across the horizon.
    s = np.sqrt(np.clip(np.sin(np.radians(elevation)), 0.0, 1.0))[..., None]
    above = (1.0 - s) * HORIZON + s * ZENITH
    blend = smoothstep(-0.5 * HORIZON_BLEND_DEG, 0.5 * HORIZON_BLEND_DEG, elevation)[..., None]
    background = blend * above + (1.0 - blend) * GROUND

    el, az = math.radians(SUN_ELEVATION_DEG), math.radians(SUN_AZIMUTH_DEG)
    sun_dir = np.array([math.sin(az) * math.cos(el), math.sin(el), -math.cos(az) * math.cos(el)])
    angle = np.degrees(np.arccos(np.clip(d @ sun_dir, -1.0, 1.0)))  # degrees from the sun's centre
    r = 0.5 * SUN_DIAMETER_DEG
    disc = (1.0 - smoothstep(r - SUN_EDGE_DEG, r, angle))[..., None]
    halo = np.exp(-((angle / 8.0) ** 2))[..., None] * blend
    img = background + halo * HALO + disc * SUN_RADIANCE

    cos_up = np.clip(d[..., 1], 0.0, None)[..., None]
    e_sun = ((disc * SUN_RADIANCE) * cos_up * d_omega[..., None]).sum(axis=(0, 1))
    e_all = (img * cos_up * d_omega[..., None]).sum(axis=(0, 1))
    stats = {"sun_dir": sun_dir, "e_sun": e_sun, "e_sky": e_all - e_sun, "sun_texels": int((disc > 0).sum())}
    return img.astype(np.float32), stats


def write_exr(path: Path, img: np.ndarray) -> None:
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(img, dtype=np.float32)}) as f:
        f.write(str(path))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default=str(Path(__file__).resolve().parent / "sky.exr"))
    a = ap.parse_args()
    img, st = sky()
    write_exr(Path(a.output), img)
    fmt = lambda v: "[" + ", ".join(f"{x:.3f}" for x in v) + "]"  # noqa: E731
    print(f"{a.output}: {WIDTH}x{HEIGHT}, sun towards {fmt(st['sun_dir'])} (map frame), "
          f"{st['sun_texels']} texels; irradiance on a horizontal surface: sun {fmt(st['e_sun'])}, "
          f"sky and halo {fmt(st['e_sky'])} W/m^2")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
