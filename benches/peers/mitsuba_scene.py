"""Translate a vkpath scene (TOML) into a Mitsuba 3 scene dict with the same radiometry.

The contract for the TOML is shared/docs/scene-format.md; what the renderer really does is in src/scene/,
src/kernel/upload.rs and shaders/*.wgsl. Everything below states which vkpath rule it reproduces and which
Mitsuba 3 convention it relies on (Mitsuba 3 documentation, "Plugin reference": sensors, emitters, BSDFs,
integrators, films, reconstruction filters; https://mitsuba.readthedocs.io/en/stable/src/plugin_reference.html).

Mapping (vkpath -> Mitsuba 3):

* camera: `fov` is HORIZONTAL in vkpath (camera.wgsl: the image plane spans [-tan(fov/2), tan(fov/2)]
  across the width, square pixels) -> `perspective` with `fov_axis = "x"`. position/look_at/up ->
  `to_world = look_at(origin, target, up)`. vkpath re-orthogonalises `up` (right = forward x up,
  up = right x forward); Mitsuba's look_at does the same. Image orientation (x right, y down, up is up):
  compare.py's unbiasedness check compares the two images pixel by pixel (a mirrored image differs by
  more than 100%; the references agree to their noise).
* aperture > 0 -> `thinlens` with `aperture_radius = aperture` (vkpath: lens RADIUS, uniform disk) and
  `focus_distance` (vkpath: distance ALONG THE VIEW AXIS to the plane in focus, camera.wgsl divides by
  dot(dir, forward); Mitsuba's thinlens focuses on the plane z = focus_distance in camera space: the same).
* pixel filter: compare.py forces `filter = "box"` on both sides: vkpath samples uniformly over the pixel
  (trace.wgsl film_position), Mitsuba `rfilter = box` (radius 0.5 px: each sample lands in its own
  pixel with weight 1, so the pixel value is the plain mean of uniformly jittered samples on both sides).
* path length: vkpath's `max_bounces` counts scattering events (diffuse, mirror and glass alike);
  0 = lights and background seen directly, 1 = direct light only. A path does next-event estimation at
  each of its first max_bounces vertices and still counts the emitter or background its last ray meets.
  Mitsuba's `max_depth` counts path segments: 1 = emitters seen directly, 2 = direct illumination.
  So max_depth = max_bounces + 1.
* Russian roulette: vkpath starts after `roulette_depth` (default 3) scattering events, with survival
  probability clamp(max(beta), 0.05, 0.95). Mitsuba's `path` starts once depth >= rr_depth (depth counts
  the scattering events done, the same test), survival min(max(throughput) * eta^2, 0.95). Same start
  (rr_depth = 3); the probabilities differ slightly (no 0.05 floor, eta^2 factor), which changes noise
  only: both are unbiased.
* point light: vkpath intensity I = power * color / (4 pi) W/sr (src/kernel/upload.rs) -> `point` emitter,
  `intensity` = I (Mitsuba: radiant intensity in W/sr).
* sphere light: a visible sphere of uniform radiance Le = power * color / (4 pi^2 r^2) that absorbs what
  hits it -> `sphere` shape + `area` emitter with `radiance` = Le and a black diffuse BSDF (Mitsuba's
  default BSDF would reflect 50%). Both sample the light by the cone it subtends (Mitsuba's sphere
  `sample_direction` does so from outside). vkpath samples every light at each diffuse vertex, Mitsuba one
  light chosen at random: identical for the course scenes, which have one light each.
* diffuse -> `diffuse` with `reflectance` = albedo, wrapped in `twosided` (vkpath shades both faces of
  every surface; Mitsuba's BSDFs are one-sided). mirror -> `conductor` with `material = "none"`
  (reflectance 1) and `specular_reflectance` = tint, `twosided`. dielectric -> `dielectric` with
  `int_ior = ior`, `ext_ior = 1` (vkpath: exact unpolarised Fresnel, reflection chosen with probability F,
  refraction with 1 - F; Mitsuba's dielectric samples the same way). Mitsuba scales transmitted radiance
  by 1/eta^2 on each crossing, vkpath does not; on every path that contributes (light leaves the glass
  before it reaches the camera: no light, camera or diffuse surface is inside glass in these scenes) the
  factors cancel, so the expectations agree.
* background -> `constant` emitter of that radiance (vkpath finds it only by escaping rays; Mitsuba
  also samples it as a light: different noise, same mean). Omitted when black.
* triangles -> one OBJ mesh per material (written next to the other temporary files), face normals,
  both faces shaded via `twosided`.

Not matched (these scenes are excluded, with the reason, by `unsupported_reasons`):
* `[[mesh]]` entries: sRGB textures (vkpath decodes and filters bilinearly its own way) and shading
  normals (vkpath ends a path whose sampled direction falls below the geometric surface; Mitsuba does
  not), so the two renderers would not compute the same image.
* `filter = "gaussian"` / `"none"` are not compared: the box filter is forced on both sides.
"""

from __future__ import annotations

import copy
import math
import os
import tomllib
from pathlib import Path

# ---------------------------------------------------------------------------------------------------
# Reading a vkpath scene, with the contract's defaults
# ---------------------------------------------------------------------------------------------------


def load_toml(path: str | os.PathLike) -> dict:
    with open(path, "rb") as f:
        return tomllib.load(f)


def _v3(x) -> list[float]:
    return [float(c) for c in x]


def _sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _norm(a) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def resolved(raw: dict) -> dict:
    """The scene with every default of scene-format.md filled in (a normalised copy)."""
    cam = raw["camera"]
    image = raw.get("image", {})
    render = raw.get("render", {})
    position = _v3(cam["position"])
    look_at = _v3(cam["look_at"])
    return {
        "camera": {
            "position": position,
            "look_at": look_at,
            "up": _v3(cam.get("up", [0.0, 1.0, 0.0])),
            "fov": float(cam["fov"]),
            "aperture": float(cam.get("aperture", 0.0)),
            "focus_distance": float(cam.get("focus_distance", _norm(_sub(look_at, position)))),
        },
        "image": {"width": int(image.get("width", 512)), "height": int(image.get("height", 512))},
        "render": {
            "samples": int(render.get("samples", 64)),
            "max_bounces": int(render.get("max_bounces", 5)),
            "seed": int(render.get("seed", 0)),
            "filter": render.get("filter", "gaussian"),
            "filter_sigma": float(render.get("filter_sigma", 0.5)),
            "background": _v3(render.get("background", [0.0, 0.0, 0.0])),
        },
        "materials": copy.deepcopy(raw.get("materials", {})),
        "sphere": copy.deepcopy(raw.get("sphere", [])),
        "triangle": copy.deepcopy(raw.get("triangle", [])),
        "mesh": copy.deepcopy(raw.get("mesh", [])),
        "light": copy.deepcopy(raw.get("light", [])),
    }


def unsupported_reasons(raw: dict) -> list[str]:
    """Why this scene cannot be rendered identically by Mitsuba 3 (empty: it can)."""
    reasons = []
    if raw.get("mesh"):
        reasons.append(
            "OBJ meshes ([[mesh]]): sRGB textures and vkpath's shading-normal rule (paths below the "
            "geometric surface end) have no exact Mitsuba counterpart"
        )
    for name, m in raw.get("materials", {}).items():
        if m.get("type") not in ("diffuse", "mirror", "dielectric"):
            reasons.append(f"material {name!r} of unknown type {m.get('type')!r}")
    for light in raw.get("light", []):
        if light.get("type") not in ("point", "sphere"):
            reasons.append(f"light of unknown type {light.get('type')!r}")
    return reasons


# ---------------------------------------------------------------------------------------------------
# A modified copy for vkpath (box filter etc.), written back as TOML
# ---------------------------------------------------------------------------------------------------


def with_overrides(raw: dict, scene_dir: str | os.PathLike, *, filter: str | None = "box",
                   width: int | None = None, height: int | None = None,
                   max_bounces: int | None = None) -> dict:
    """A copy of the raw scene with [render]/[image] keys replaced; mesh paths made absolute so that the
    copy can live anywhere."""
    out = copy.deepcopy(raw)
    render = out.setdefault("render", {})
    image = out.setdefault("image", {})
    if filter is not None:
        render["filter"] = filter
        if filter != "gaussian":
            render.pop("filter_sigma", None)
    if width is not None:
        image["width"] = int(width)
    if height is not None:
        image["height"] = int(height)
    if max_bounces is not None:
        render["max_bounces"] = int(max_bounces)
    for m in out.get("mesh", []):
        for key in ("obj", "texture"):
            if key in m:
                m[key] = str((Path(scene_dir) / m[key]).resolve())
    return out


def render_key(raw: dict) -> str:
    """What determines the linear image given --spp and --seed: two scenes with the same key render the
    same EXR (comments, samples, seed, gamma and exposure do not enter)."""
    import json

    r = resolved(raw)
    r["render"].pop("samples")
    r["render"].pop("seed")
    if r["render"]["filter"] != "gaussian":
        r["render"].pop("filter_sigma")
    return json.dumps(r, sort_keys=True)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _toml_key(k: str) -> str:
    return k if k.replace("_", "").replace("-", "").isalnum() else _toml_value(k)


def dump_toml(raw: dict) -> str:
    """Writes the subset of TOML that scene files use: tables of scalars/arrays, a table of inline tables
    ([materials]) and arrays of tables ([[sphere]] ...)."""
    lines = ["# Written by benches/peers/mitsuba_scene.py (a modified copy of a vkpath scene)."]
    for name, value in raw.items():
        if isinstance(value, dict):
            lines.append(f"\n[{name}]")
            for k, v in value.items():
                lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        elif isinstance(value, list) and all(isinstance(x, dict) for x in value):
            for item in value:
                lines.append(f"\n[[{name}]]")
                for k, v in item.items():
                    lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        else:
            raise ValueError(f"unexpected top-level key {name!r}")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------------
# The Mitsuba 3 scene dict
# ---------------------------------------------------------------------------------------------------


def _rgb(value) -> dict:
    return {"type": "rgb", "value": _v3(value)}


def _bsdf(material: dict) -> dict:
    kind = material["type"]
    if kind == "diffuse":
        # vkpath shades both faces; Mitsuba's diffuse is one-sided -> twosided (plugin reference, BSDFs).
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": _rgb(material["albedo"])}}
    if kind == "mirror":
        # conductor with material "none": a perfect mirror of reflectance 1, times specular_reflectance.
        return {
            "type": "twosided",
            "bsdf": {
                "type": "conductor",
                "material": "none",
                "specular_reflectance": _rgb(material.get("tint", [1.0, 1.0, 1.0])),
            },
        }
    if kind == "dielectric":
        return {"type": "dielectric", "int_ior": float(material["ior"]), "ext_ior": 1.0}
    raise ValueError(f"unsupported material type {kind!r}")


def _black_bsdf() -> dict:
    return {"type": "diffuse", "reflectance": _rgb([0.0, 0.0, 0.0])}


def _write_obj(path: Path, triangles: list[list[list[float]]]) -> None:
    with open(path, "w") as f:
        f.write("# triangles of a vkpath scene, written by benches/peers/mitsuba_scene.py\n")
        for tri in triangles:
            for v in tri:
                f.write("v {:.9g} {:.9g} {:.9g}\n".format(*v))
        for i in range(len(triangles)):
            f.write(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n")


def mitsuba_dict(mi, raw: dict, *, spp: int, tmp_dir: str | os.PathLike, rr_depth: int = 3) -> dict:
    """The Mitsuba 3 scene dict for `raw` (already overridden: size, bounces, filter). `mi` is the mitsuba
    module with a variant set. Triangles are written as OBJ files under tmp_dir."""
    reasons = unsupported_reasons(raw)
    if reasons:
        raise ValueError("; ".join(reasons))
    s = resolved(raw)
    cam, image, render = s["camera"], s["image"], s["render"]
    if render["filter"] != "box":
        raise ValueError(f"only the box filter is matched (scene has {render['filter']!r})")

    to_world = mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"])
    sensor = {
        "type": "perspective",
        "fov": cam["fov"],
        "fov_axis": "x",  # vkpath's fov is horizontal (scene-format.md, camera.wgsl)
        "to_world": to_world,
        "near_clip": 1e-3,
        "far_clip": 1e6,  # the course's wall spheres reach 2000 units away; never clip them
        "sampler": {"type": "independent", "sample_count": int(spp)},
        "film": {
            "type": "hdrfilm",
            "width": image["width"],
            "height": image["height"],
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
            "component_format": "float32",
        },
    }
    if cam["aperture"] > 0.0:
        sensor["type"] = "thinlens"
        sensor["aperture_radius"] = cam["aperture"]
        sensor["focus_distance"] = cam["focus_distance"]

    integrator = {
        "type": "path",
        # Mitsuba counts segments (1 = emitters only, 2 = direct light), vkpath scattering events.
        "max_depth": render["max_bounces"] + 1,
        "rr_depth": int(rr_depth),
        "hide_emitters": False,
    }

    scene: dict = {"type": "scene", "integrator": integrator, "sensor": sensor}
    materials = s["materials"]
    for name, m in materials.items():
        scene[f"bsdf-{name}"] = {**_bsdf(m), "id": f"bsdf-{name}"}

    for i, sph in enumerate(s["sphere"]):
        scene[f"sphere-{i:03d}"] = {
            "type": "sphere",
            "center": _v3(sph["center"]),
            "radius": float(sph["radius"]),
            "bsdf": {"type": "ref", "id": f"bsdf-{sph['material']}"},
        }

    by_material: dict[str, list] = {}
    for tri in s["triangle"]:
        by_material.setdefault(tri["material"], []).append([_v3(v) for v in tri["vertices"]])
    if by_material:
        tmp_dir = Path(tmp_dir)
        tmp_dir.mkdir(parents=True, exist_ok=True)
    for j, (name, tris) in enumerate(by_material.items()):
        path = Path(tmp_dir) / f"triangles-{j}.obj"
        _write_obj(path, tris)
        scene[f"triangles-{j}"] = {
            "type": "obj",
            "filename": str(path),
            "face_normals": True,
            "bsdf": {"type": "ref", "id": f"bsdf-{name}"},
        }

    for k, light in enumerate(s["light"]):
        color = _v3(light.get("color", [1.0, 1.0, 1.0]))
        power = float(light["power"])
        if light["type"] == "point":
            intensity = [c * power / (4.0 * math.pi) for c in color]  # W/sr, as src/kernel/upload.rs
            scene[f"light-{k}"] = {"type": "point", "position": _v3(light["position"]),
                                   "intensity": _rgb(intensity)}
        else:
            r = float(light["radius"])
            le = [c * power / (4.0 * math.pi ** 2 * r * r) for c in color]  # radiance, as src/kernel/upload.rs
            scene[f"light-{k}"] = {
                "type": "sphere",
                "center": _v3(light["center"]),
                "radius": r,
                "bsdf": _black_bsdf(),  # vkpath's emitter absorbs everything that hits it
                "emitter": {"type": "area", "radiance": _rgb(le)},
            }

    if any(c != 0.0 for c in render["background"]):
        scene["background"] = {"type": "constant", "radiance": _rgb(render["background"])}
    return scene
