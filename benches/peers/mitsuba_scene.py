"""Translate a vkpath scene (TOML) into a Mitsuba 3 scene dict with the same radiometry.

The contract for the TOML is docs/scene-format.md; what the renderer really does is in src/scene/,
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
* camera.type = "orthographic" -> `orthographic` with
  `to_world = look_at(origin, target, up) @ scale(extent/2, extent/2, 1)`. Mitsuba's orthographic sensor
  sees camera-space x in [-1, 1] across the image width and y in [-1/aspect, 1/aspect] (square pixels); the
  scale makes the view `extent` wide with the height following the image, as vkpath (camera.wgsl:
  film_to_plane with half_width = extent / 2, rays parallel to the view direction from the plane through
  `position`). Mitsuba starts its rays `near_clip` along the view axis (default 0.01, must be > 0) ->
  near_clip = 1e-6. Verified with Mitsuba 3.6.4: extent 4 on a 16x8 image, an emitting strip 2 wide lights
  exactly the middle 8 columns and a strip 1 high the middle 4 rows; the ray for film x = 1/4 starts at
  camera-space x = -1 (left is left).
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
* roughness (conductor, dielectric, plastic): perceptual, one number r or [u, v]; GGX alpha = r^2 in vkpath
  (src/scene/mod.rs Roughness::alpha), and an alpha below SMOOTH_ALPHA = 1e-3 on both axes
  (shaders/microfacet.wgsl; roughness below ~0.032) is a smooth, delta interface there -> the smooth
  Mitsuba BSDF then, else its rough one with `distribution = "ggx"`, `alpha` = r^2 and
  `sample_visible = true` (vkpath samples by visible normals too, Heitz 2018; noise only anyway).
  Anisotropic [u, v] with u != v is not translated (below).
* conductor -> `twosided` (vkpath shades both faces) `conductor` (smooth: a mirror whose reflectance is
  the conductor's Fresnel) or `roughconductor`. `preset` gold, silver, copper, aluminium -> `material` =
  "Au", "Ag", "Cu", "Al": vkpath's presets (src/scene/mod.rs CONDUCTOR_PRESETS) are Mitsuba 3.6.4's RGB
  reduction of those spectral tables (conductor_presets.py prints them), so the metal is the same.
  `eta` and `k` -> `eta`, `k` as `srgb` spectra with `unbounded = true` (Mitsuba's `rgb` shorthand is a
  reflectance and refuses values above 1); checked with 3.6.4: `conductor` and `roughconductor` with gold's
  eta/k given so evaluate and sample exactly as with `material = "Au"`. Both use the exact unpolarised
  Fresnel equations of a complex index per channel, `specular_reflectance` 1.
* rough dielectric -> `roughdielectric`, `int_ior = ior`, `ext_ior = 1` (one-sided as glass is in vkpath):
  Walter et al. 2007, reflection or refraction off the sampled microfacet chosen with probability F, as
  vkpath. The 1/eta^2 radiance scaling cancels as for smooth glass.
* plastic (a diffuse base of albedo a under a dielectric coat of index `ior`, default 1.5) -> `twosided`
  `plastic` (smooth coat) or `roughplastic`, `diffuse_reflectance` = albedo, `int_ior = ior`,
  `ext_ior = 1`, `specular_reflectance` 1, `nonlinear = true`. With a smooth coat vkpath's model is
  exactly Mitsuba's (shaders/bsdfs/plastic.wgsl): specular F(cos_o), diffuse
  (1 - F(cos_i)) (1 - F(cos_o)) a / (pi eta^2 (1 - a Fdr_int)), nonlinear being the a in the denominator.
  With a rough coat the models differ: vkpath keeps the smooth interface's 1 - F for the light
  crossing the coat to and from the base, Mitsuba's `roughplastic` uses its precomputed rough-coat
  transmittance tables (and their hemispherical average for Fdr_int), which lose much more energy. So for
  roughness > 0 the two renderers do not compute the same image, and compare.py's unbiasedness check
  fails on purpose. Measured with 3.6.4 (a plastic ball of albedo 0.8, ior 1.5, under a uniform white
  environment, 64x64, 2048 spp each; the ball's mean radiance, vkpath / Mitsuba): roughness 0:
  0.6653 / 0.6656 (the same); 0.1: 0.6651 / 0.6578 (+1.1%); 0.3: 0.6534 / 0.6285 (+4.0%); 0.5:
  0.633 / 0.537 (+18%); 0.7: 0.615 / 0.416 (+48%). Mitsuba's roughplastic of white albedo reflects
  0.98, 0.92, 0.74 and 0.55 of the light at normal incidence for roughness 0.1, 0.3, 0.5, 0.7 (mitsuba3
  issue #1155 reports its furnace test too); its smooth plastic 1.00.
* render.background, and `[environment] radiance` without a map -> `constant` emitter of that radiance
  (Mitsuba samples it as a light too; vkpath's strategies differ in noise, not in mean). Omitted when black.
  The contract says [environment] replaces render.background; a scene that sets both (background not
  black) is not translated (unsupported_reasons: which one wins is not specified). Checked: a white
  (albedo 1) diffuse sphere under a uniform [environment] radiance = [1, 1, 1] renders 1.00003 on average
  (64x64, 256 spp; each pixel 1 within its noise).
* `[environment] map` -> `envmap` with `filename` = the map's absolute path (relative paths are taken
  relative to the scene file: with_overrides makes them absolute in the copy, mitsuba_dict takes scene_dir)
  and `to_world = rotate(axis = [0, 1, 0], angle = rotate)` (degrees). `radiance` multiplies the map: a
  uniform [s, s, s] becomes `scale = s`; a non-uniform tint, which Mitsuba's scalar `scale` cannot express,
  is applied to the texels instead (the map is read with mi.Bitmap, multiplied per channel and handed over
  as `bitmap`): the same radiance, since Mitsuba's lookup is linear in the texels. Black radiance: omitted.
  Mitsuba 3.6.4's envmap, which vkpath reproduces (verified by evaluating Emitter.eval for chosen directions
  on a map whose texels hold their own column and row indices):
    - a world direction w (from the scene towards the sky; the ray direction) is taken to the map's frame
      by d = to_world^-1 w; u = atan2(d.x, -d.z) / (2 pi), wrapped into [0, 1); v = acos(d.y) / pi. So the
      image's top row is +y (up), its left edge and right edge are -z, u = 1/4 is +x, u = 1/2 (the middle
      column) is +z and u = 3/4 is -x;
    - texel lookup, W x H texels: continuous coordinates x = u W - 1/2 (periodic: column W is column 0)
      and y = v (H - 1), bilinear between the four texels around (x, y). So texel (i, j) sits at
      u = (i + 1/2) / W but at v = j / (H - 1): rows 0 and H-1 lie ON the poles (not at (j + 1/2) / H);
      probed: u = 2.5 / W, v = 2 / (H - 1) returns exactly texel (2, 2), v = 2.5 / (H - 1) the mean of rows
      2 and 3. (Exactly straight down, d.y = -1, Mitsuba wraps v = 1 to 0 and returns row 0; a set of
      directions of measure zero.)
    - rotate(axis = [0, 1, 0], angle = a) is the right-handed rotation about +y (counter-clockwise seen
      from above): world = R(a) local; R(90) takes local +z to world +x and local +x to world -z. Probed:
      with rotate = 90 the world direction +x returns the texels at u = 1/2 (the map's +z) and world +z those at
      u = 3/4 (the map's -x). In terms of the map's azimuth phi = atan2(x, -z) = 2 pi u: a sun drawn at
      phi0 appears in the world at azimuth phi0 - rotate (the same elevation).
    - Mitsuba samples the map by luminance x sin(theta), vkpath its own way: noise only.
* `[[light]] type = "directional"`, angle = 0 -> `directional` with `direction` = direction / |direction|
  (the way the light travels, as vkpath) and `irradiance` = irradiance * color (W m^-2 on a surface facing it).
  Verified: a white (albedo 1) diffuse floor under irradiance 3 from straight above renders 3 / pi = 0.95493.
* `type = "emitter"` material -> black `diffuse` BSDF (vkpath's emitter reflects nothing) plus an `area`
  emitter with `radiance` on every shape that uses it; `emission` on a diffuse, mirror or dielectric
  material -> that material's BSDF plus an `area` emitter with `radiance` = emission. Spheres get one each;
  triangles, written as one OBJ mesh per material, get one per mesh (Mitsuba samples a mesh emitter
  uniformly by area; noise only). Mitsuba's area emitter emits only towards the side the surface normal
  faces: verified with 3.6.4, a triangle written by _write_obj in vkpath's vertex order (v0, v1, v2) has
  Mitsuba normal (v1 - v0) x (v2 - v0) (the OBJ keeps the winding; face_normals) and shows its radiance
  exactly from that side, black from the other; a sphere shows it from outside, black from inside
  (Mitsuba's sphere normals point outwards). That is vkpath's front side (triangle normal (v1 - v0) x (v2 - v0),
  sphere outward): the one-sided emission matches.
* render.light_sampling ("cone", "area", "none", "mis") only chooses vkpath's estimator; Mitsuba's `path`
  always combines emitter and BSDF sampling by MIS. Unbiased either way: the same expected image.
* triangles -> one OBJ mesh per material (written next to the other temporary files), face normals,
  both faces shaded via `twosided`.

Not matched (these scenes are excluded, with the reason, by `unsupported_reasons`):
* `[[mesh]]` entries: sRGB textures (vkpath decodes and filters bilinearly its own way) and shading
  normals (vkpath ends a path whose sampled direction falls below the geometric surface; Mitsuba does
  not), so the two renderers would not compute the same image.
* `filter = "gaussian"` / `"none"` are not compared: the box filter is forced on both sides.
* Two-sided emission (`two_sided = true` on an emitter material, `two_sided_emission = true`): Mitsuba 3's
  `area` emitter has no two-sided option (3.6.4 refuses `twosided` as an unreferenced property). Two
  coincident, opposite-facing emitters are no stand-in (which of two coincident surfaces a ray meets is
  arbitrary, so half of the hits would see the dark side), and copies moved apart change the geometry.
* A directional light with angle > 0 (a sun disc of uniform radiance): Mitsuba's `directional` is a delta
  light only, and no other Mitsuba emitter is a uniform cone of directions (a map would pixelate the disc,
  a distant sphere shows parallax).
* `metallic_roughness` (glTF 2.0's model): no Mitsuba 3 BSDF is that model (`principled` is Disney's,
  with other lobes and Fresnel).
* A conductor with `base_color` (Schlick's Fresnel from the reflectance at normal incidence): Mitsuba 3's
  `conductor` and `roughconductor` take a complex index of refraction only.
* Anisotropic roughness ([u, v], u != v, not both below the smooth threshold): `alpha_u` / `alpha_v`
  (= u^2, v^2) would lie along Mitsuba's tangent frame, which is not vkpath's (shaders/scene.wgsl
  surface_tangent: (0, 1, 0) x n on a sphere, v1 - v0 on a triangle; Mitsuba: a sphere's dp/du runs around
  its local z axis, an OBJ without texture coordinates gets an arbitrary frame), so the highlights would
  stretch along other directions. (For spheres, a Mitsuba sphere turned so that its local z is world +y
  would have vkpath's tangent up to sign, which anisotropy does not see: a possible extension, not done.)
* Material types other than diffuse, mirror, dielectric, conductor, plastic and emitter, light types other
  than point, sphere and directional, camera types other than perspective and orthographic.
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


BLACK = [0.0, 0.0, 0.0]
WHITE = [1.0, 1.0, 1.0]


def _material(m: dict) -> dict:
    """A material with its defaults (scene-format.md and its Additions)."""
    out = copy.deepcopy(m)
    kind = out.get("type")
    if kind == "emitter":
        out["radiance"] = _v3(out.get("radiance", BLACK))
        out["two_sided"] = bool(out.get("two_sided", False))
    elif kind in ("diffuse", "mirror", "dielectric", "conductor", "plastic"):
        if kind == "mirror":
            out["tint"] = _v3(out.get("tint", WHITE))
        if kind in ("dielectric", "conductor", "plastic"):
            out["roughness"] = _roughness(out.get("roughness", 0.0))
        if kind == "plastic":
            out["ior"] = float(out.get("ior", PLASTIC_DEFAULT_IOR))
        out["emission"] = _v3(out.get("emission", BLACK))
        out["two_sided_emission"] = bool(out.get("two_sided_emission", False))
    return out


PLASTIC_DEFAULT_IOR = 1.5  # scene-format.md: a plastic's coat, when `ior` is not given

# vkpath's conductor presets (src/scene/mod.rs CONDUCTOR_PRESETS) are Mitsuba 3.6.4's RGB values of these
# `material` names (benches/peers/conductor_presets.py prints them).
CONDUCTOR_PRESETS = {"gold": "Au", "silver": "Ag", "copper": "Cu", "aluminium": "Al"}


# shaders/microfacet.wgsl: a GGX alpha below this on both axes is a smooth (delta) interface in vkpath.
SMOOTH_ALPHA = 1e-3


def _smooth(u: float, v: float) -> bool:
    return max(u * u, v * v) < SMOOTH_ALPHA


def _roughness(r) -> list[float]:
    """`roughness` as [along u, along v]: one number is isotropic."""
    if isinstance(r, (int, float)):
        return [float(r), float(r)]
    return [float(c) for c in r]


def _light(light: dict) -> dict:
    out = copy.deepcopy(light)
    out["color"] = _v3(out.get("color", WHITE))
    if out.get("type") == "directional":
        out["angle"] = float(out.get("angle", 0.0))
    return out


def _environment(raw: dict) -> dict | None:
    """[environment] with its defaults: radiance (black without a map, white with one), map (the path as
    written, None without), rotate (degrees about +y); None when the scene has no [environment]."""
    env = raw.get("environment")
    if env is None:
        return None
    has_map = env.get("map") is not None
    return {
        "radiance": _v3(env.get("radiance", WHITE if has_map else BLACK)),
        "map": env.get("map"),
        "rotate": float(env.get("rotate", 0.0)),
    }


def emission_of(material: dict) -> list[float]:
    """The front-side radiance a (resolved) material emits: black for most."""
    if material.get("type") == "emitter":
        return _v3(material.get("radiance", BLACK))
    return _v3(material.get("emission", BLACK))


def resolved(raw: dict) -> dict:
    """The scene with every default of scene-format.md filled in (a normalised copy)."""
    cam = raw["camera"]
    image = raw.get("image", {})
    render = raw.get("render", {})
    position = _v3(cam["position"])
    look_at = _v3(cam["look_at"])
    kind = cam.get("type", "perspective")
    return {
        "camera": {
            "type": kind,
            "position": position,
            "look_at": look_at,
            "up": _v3(cam.get("up", [0.0, 1.0, 0.0])),
            # perspective: the horizontal fov (degrees); orthographic: the view's width (scene units)
            "fov": float(cam["fov"]) if "fov" in cam else None,
            "extent": float(cam["extent"]) if "extent" in cam else None,
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
            "background": _v3(render.get("background", BLACK)),
            # vkpath's estimators (docs/scene-format.md): they change the noise, not the expected image
            "sampler": render.get("sampler", "independent"),
            "light_sampling": render.get("light_sampling", "cone"),
        },
        "environment": _environment(raw),
        "materials": {name: _material(m) for name, m in raw.get("materials", {}).items()},
        "sphere": copy.deepcopy(raw.get("sphere", [])),
        "triangle": copy.deepcopy(raw.get("triangle", [])),
        "mesh": copy.deepcopy(raw.get("mesh", [])),
        "light": [_light(li) for li in raw.get("light", [])],
    }


def unsupported_reasons(raw: dict) -> list[str]:
    """Why this scene cannot be rendered identically by Mitsuba 3 (empty: it can)."""
    reasons = []
    if raw.get("mesh"):
        reasons.append(
            "OBJ meshes ([[mesh]]): sRGB textures and vkpath's shading-normal rule (paths below the "
            "geometric surface end) have no exact Mitsuba counterpart"
        )
    kind = raw.get("camera", {}).get("type", "perspective")
    if kind not in ("perspective", "orthographic"):
        reasons.append(f"camera of unknown type {kind!r}")
    for name, m in raw.get("materials", {}).items():
        kind = m.get("type")
        if kind == "metallic_roughness":
            reasons.append(
                f"material {name!r} is glTF's metallic_roughness: Mitsuba 3 has no such BSDF (its "
                "`principled` is Disney's model, another one)"
            )
        elif kind not in ("diffuse", "mirror", "dielectric", "conductor", "plastic", "emitter"):
            reasons.append(f"material {name!r} of type {kind!r} (not translated)")
        if kind == "conductor" and "base_color" in m:
            reasons.append(
                f"material {name!r} is a conductor with base_color (Schlick's Fresnel): Mitsuba 3's "
                "conductors take a complex index of refraction only"
            )
        if kind in ("dielectric", "conductor", "plastic"):
            u, v = _roughness(m.get("roughness", 0.0))
            if u != v and not _smooth(u, v):
                reasons.append(
                    f"material {name!r} has anisotropic roughness [{u}, {v}]: vkpath's tangent frame "
                    "(spheres: (0, 1, 0) x n; triangles: v1 - v0) is not Mitsuba's, so alpha_u and "
                    "alpha_v would lie along other directions"
                )
        if m.get("two_sided") or m.get("two_sided_emission"):
            reasons.append(
                f"material {name!r} emits from both sides: Mitsuba 3's area emitter is one-sided only "
                "(coincident opposite emitters would show the dark side to half the rays; offset copies "
                "change the geometry)"
            )
    for light in raw.get("light", []):
        if light.get("type") not in ("point", "sphere", "directional"):
            reasons.append(f"light of unknown type {light.get('type')!r}")
        elif light["type"] == "directional" and float(light.get("angle", 0.0)) > 0.0:
            reasons.append(
                f"directional light with angle {light['angle']} > 0: Mitsuba's `directional` is a delta "
                "light; no Mitsuba emitter is a uniform cone of directions"
            )
    env = raw.get("environment")
    background = raw.get("render", {}).get("background")
    if env is not None and background is not None and any(float(c) != 0.0 for c in background):
        reasons.append("both render.background and [environment]: the contract does not say which one "
                       "lights the scene")
    return reasons


# ---------------------------------------------------------------------------------------------------
# A modified copy for vkpath (box filter etc.), written back as TOML
# ---------------------------------------------------------------------------------------------------


def with_overrides(raw: dict, scene_dir: str | os.PathLike, *, filter: str | None = "box",
                   width: int | None = None, height: int | None = None,
                   max_bounces: int | None = None) -> dict:
    """A copy of the raw scene with [render]/[image] keys replaced; mesh and environment-map paths made
    absolute so that the copy can live anywhere."""
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
    env = out.get("environment")
    if env is not None and env.get("map") is not None:
        env["map"] = str((Path(scene_dir) / env["map"]).resolve())
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
    cam = r["camera"]
    if cam["type"] == "orthographic":
        cam.pop("focus_distance")  # no lens: the focus does not enter
    elif cam["aperture"] == 0.0:
        cam.pop("focus_distance")  # pinhole: the focus does not enter
    # render.background and a map-less [environment] mean the same uniform radiance: one form in the key.
    env = r["environment"] or {"radiance": r["render"]["background"], "map": None, "rotate": 0.0}
    r["render"].pop("background")
    if env["map"] is None:
        env.pop("rotate")  # a uniform environment is the same however turned
    r["environment"] = None if env["map"] is None and all(c == 0.0 for c in env["radiance"]) else env
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
        alpha = _alpha(material)
        if alpha == 0.0 or float(material["ior"]) == 1.0:  # vkpath: an index-matched surface is smooth
            return {"type": "dielectric", "int_ior": float(material["ior"]), "ext_ior": 1.0}
        # Walter et al. 2007 with GGX, alpha = roughness^2, sampled by visible normals (as vkpath).
        return {"type": "roughdielectric", "distribution": "ggx", "alpha": alpha,
                "int_ior": float(material["ior"]), "ext_ior": 1.0, "sample_visible": True}
    if kind == "conductor":
        alpha = _alpha(material)
        if "preset" in material:
            fresnel = {"material": CONDUCTOR_PRESETS[material["preset"]]}
        elif "eta" in material and "k" in material:
            # `srgb` with unbounded = true: the `rgb` shorthand is a reflectance and refuses values > 1.
            fresnel = {"eta": {"type": "srgb", "color": _v3(material["eta"]), "unbounded": True},
                       "k": {"type": "srgb", "color": _v3(material["k"]), "unbounded": True}}
        else:
            raise ValueError("a conductor with base_color (Schlick's Fresnel) has no Mitsuba counterpart")
        if alpha == 0.0:
            inner = {"type": "conductor", **fresnel}  # a mirror with the conductor's Fresnel
        else:
            inner = {"type": "roughconductor", "distribution": "ggx", "alpha": alpha,
                     "sample_visible": True, **fresnel}
        return {"type": "twosided", "bsdf": inner}
    if kind == "plastic":
        alpha = _alpha(material)
        inner = {
            "type": "plastic" if alpha == 0.0 else "roughplastic",
            "diffuse_reflectance": _rgb(material["albedo"]),
            "int_ior": float(material["ior"]),
            "ext_ior": 1.0,
            "nonlinear": True,  # a / (1 - a Fdr_int): the internal reflections tinted by the base, as vkpath
        }
        if alpha > 0.0:
            # Mitsuba's diffuse transmission is its rough-coat table; vkpath's the smooth coat's 1 - F
            # (the docstring: the two differ slightly there).
            inner.update(distribution="ggx", alpha=alpha, sample_visible=True)
        return {"type": "twosided", "bsdf": inner}
    raise ValueError(f"unsupported material type {kind!r}")


def _alpha(material: dict) -> float:
    """The GGX alpha of an isotropic roughness (unsupported_reasons refuses anisotropic ones); 0 where
    vkpath treats the surface as smooth (alpha below SMOOTH_ALPHA on both axes)."""
    u, v = _roughness(material.get("roughness", 0.0))
    if _smooth(u, v):
        return 0.0
    if u != v:
        raise ValueError(f"anisotropic roughness [{u}, {v}] is not translated")
    return u * u


def _black_bsdf() -> dict:
    return {"type": "diffuse", "reflectance": _rgb([0.0, 0.0, 0.0])}


def _material_bsdf(material: dict) -> dict:
    """The BSDF of a (resolved) material: an emitter-type material reflects nothing."""
    if material["type"] == "emitter":
        return _black_bsdf()
    return _bsdf(material)


def _area_emitter(material: dict) -> dict | None:
    """The `area` emitter a shape of this (resolved) material carries, None when it does not emit. Mitsuba's
    area emitter emits on the side the shape's normal faces, as vkpath's one-sided emission."""
    le = emission_of(material)
    if all(c == 0.0 for c in le):
        return None
    return {"type": "area", "radiance": _rgb(le)}


def _environment_emitter(mi, env: dict, scene_dir: str | os.PathLike | None) -> dict | None:
    """`envmap` (with a map) or `constant` (without) for a resolved [environment]; None when black."""
    radiance = env["radiance"]
    if all(c == 0.0 for c in radiance):
        return None
    if env["map"] is None:
        return {"type": "constant", "radiance": _rgb(radiance)}
    path = Path(env["map"])
    if not path.is_absolute():
        if scene_dir is None:
            raise ValueError(f"environment map {env['map']!r} is relative: pass scene_dir (the scene "
                             "file's folder) or a copy from with_overrides")
        path = Path(scene_dir) / path
    path = path.resolve()
    emitter = {
        "type": "envmap",
        # world = R local, R the right-handed rotation about +y by `rotate` degrees (see the docstring)
        "to_world": mi.ScalarTransform4f().rotate(axis=[0.0, 1.0, 0.0], angle=env["rotate"]),
    }
    if radiance[0] == radiance[1] == radiance[2]:
        emitter["filename"] = str(path)
        if radiance[0] != 1.0:
            emitter["scale"] = radiance[0]
    else:
        # A per-channel tint: Mitsuba's `scale` is a scalar, so the texels are tinted instead (the lookup
        # is bilinear, hence linear in the texels: the same radiance as vkpath's map x radiance).
        import numpy as np

        bitmap = mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
        texels = np.array(bitmap, dtype=np.float32) * np.array(radiance, dtype=np.float32)
        emitter["bitmap"] = mi.Bitmap(np.ascontiguousarray(texels, dtype=np.float32))
    return emitter


def _write_obj(path: Path, triangles: list[list[list[float]]]) -> None:
    with open(path, "w") as f:
        f.write("# triangles of a vkpath scene, written by benches/peers/mitsuba_scene.py\n")
        for tri in triangles:
            for v in tri:
                f.write("v {:.9g} {:.9g} {:.9g}\n".format(*v))
        for i in range(len(triangles)):
            f.write(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n")


def mitsuba_dict(mi, raw: dict, *, spp: int, tmp_dir: str | os.PathLike, rr_depth: int = 3,
                 scene_dir: str | os.PathLike | None = None, sampler: str = "independent") -> dict:
    """The Mitsuba 3 scene dict for `raw` (already overridden: size, bounces, filter). `mi` is the mitsuba
    module with a variant set. Triangles are written as OBJ files under tmp_dir. A relative environment
    map is found relative to scene_dir (with_overrides makes it absolute already). `sampler` is the
    sensor's Mitsuba sampler plugin (independent, stratified, multijitter, orthogonal, ldsampler)."""
    reasons = unsupported_reasons(raw)
    if reasons:
        raise ValueError("; ".join(reasons))
    s = resolved(raw)
    cam, image, render = s["camera"], s["image"], s["render"]
    if render["filter"] != "box":
        raise ValueError(f"only the box filter is matched (scene has {render['filter']!r})")

    to_world = mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"])
    if cam["type"] == "orthographic":
        # Mitsuba's view spans camera-space x in [-1, 1] across the width: scale it to extent / 2.
        half = 0.5 * cam["extent"]
        projection = {"type": "orthographic",
                      "to_world": to_world @ mi.ScalarTransform4f().scale([half, half, 1.0]),
                      "near_clip": 1e-6}  # rays start (almost) on the plane through position, as vkpath's
    else:
        projection = {"type": "perspective",
                      "fov": cam["fov"],
                      "fov_axis": "x",  # vkpath's fov is horizontal (scene-format.md, camera.wgsl)
                      "to_world": to_world,
                      "near_clip": 1e-3}
    sensor = {
        **projection,
        "far_clip": 1e6,  # the course's wall spheres reach 2000 units away; never clip them
        "sampler": {"type": sampler, "sample_count": int(spp)},
        "film": {
            "type": "hdrfilm",
            "width": image["width"],
            "height": image["height"],
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
            "component_format": "float32",
        },
    }
    if cam["aperture"] > 0.0 and cam["type"] == "perspective":
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
        scene[f"bsdf-{name}"] = {**_material_bsdf(m), "id": f"bsdf-{name}"}

    for i, sph in enumerate(s["sphere"]):
        shape = {
            "type": "sphere",
            "center": _v3(sph["center"]),
            "radius": float(sph["radius"]),
            "bsdf": {"type": "ref", "id": f"bsdf-{sph['material']}"},
        }
        emitter = _area_emitter(materials[sph["material"]])  # outward, as vkpath's sphere normal
        if emitter is not None:
            shape["emitter"] = emitter
        scene[f"sphere-{i:03d}"] = shape

    by_material: dict[str, list] = {}
    for tri in s["triangle"]:
        by_material.setdefault(tri["material"], []).append([_v3(v) for v in tri["vertices"]])
    if by_material:
        tmp_dir = Path(tmp_dir)
        tmp_dir.mkdir(parents=True, exist_ok=True)
    for j, (name, tris) in enumerate(by_material.items()):
        path = Path(tmp_dir) / f"triangles-{j}.obj"
        _write_obj(path, tris)
        shape = {
            "type": "obj",
            "filename": str(path),
            "face_normals": True,  # normal (v1 - v0) x (v2 - v0): _write_obj keeps vkpath's vertex order
            "bsdf": {"type": "ref", "id": f"bsdf-{name}"},
        }
        emitter = _area_emitter(materials[name])
        if emitter is not None:
            shape["emitter"] = emitter
        scene[f"triangles-{j}"] = shape

    for k, light in enumerate(s["light"]):
        color = light["color"]
        if light["type"] == "directional":
            d = _v3(light["direction"])
            n = _norm(d)
            scene[f"light-{k}"] = {
                "type": "directional",
                "direction": [c / n for c in d],  # the way the light travels, as vkpath's
                "irradiance": _rgb([float(light["irradiance"]) * c for c in color]),  # W/m^2 facing it
            }
            continue
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

    env = s["environment"]
    if env is None:
        env = {"radiance": render["background"], "map": None, "rotate": 0.0}  # the same uniform radiance
    emitter = _environment_emitter(mi, env, scene_dir)
    if emitter is not None:
        scene["environment"] = emitter
    return scene


# ---------------------------------------------------------------------------------------------------
# Rendering one scene with Mitsuba 3 (a check of the translation; compare.py does the comparisons)
# ---------------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    """python mitsuba_scene.py SCENE.toml -o OUT.png|OUT.exr [--spp N] [--size W] [--max-bounces N]: render a
    vkpath scene with Mitsuba 3 through mitsuba_dict (box filter), print the image mean per channel."""
    import argparse
    import sys
    import tempfile

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("scene", help="a vkpath scene (.toml)")
    ap.add_argument("-o", "--output", required=True, help=".exr (linear) or .png (sRGB-encoded, clamped)")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--size", type=int, help="image width (the height keeps the aspect); default the scene's")
    ap.add_argument("--max-bounces", type=int, help="override render.max_bounces")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from compare import import_mitsuba  # LLVM 19 for Dr.Jit, llvm_ad_rgb

    _, mi, _ = import_mitsuba()
    raw = load_toml(a.scene)
    reasons = unsupported_reasons(raw)
    if reasons:
        sys.exit("mitsuba_scene.py: not translatable: " + "; ".join(reasons))
    r = resolved(raw)
    width = a.size or r["image"]["width"]
    height = max(1, round(width * r["image"]["height"] / r["image"]["width"]))
    over = with_overrides(raw, Path(a.scene).parent, filter="box", width=width, height=height,
                          max_bounces=a.max_bounces)
    with tempfile.TemporaryDirectory() as tmp:
        scene = mi.load_dict(mitsuba_dict(mi, over, spp=a.spp, tmp_dir=tmp))
        img = mi.render(scene, spp=a.spp, seed=a.seed)
    out = Path(a.output)
    if out.suffix.lower() == ".png":
        mi.util.write_bitmap(str(out), img, write_async=False)  # sRGB transfer curve, 8 bit
    else:
        mi.Bitmap(img).write(str(out))
    import numpy as np

    mean = np.array(img, dtype=np.float64).reshape(-1, 3).mean(axis=0)
    print(f"{out}: {width}x{height}, {a.spp} spp, mean RGB {mean[0]:.5f} {mean[1]:.5f} {mean[2]:.5f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
