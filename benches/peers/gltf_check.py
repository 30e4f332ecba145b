#!/usr/bin/env python3
"""glTF files rendered by vkpath and by Blender's Cycles (bpy, its glTF importer) under the same camera,
environment, pixel filter and path length; the image means side by side (issue "glTF assets as people
have them").

    benches/peers/setup_cycles.sh
    benches/peers/.venv-cycles/bin/python benches/peers/gltf_check.py FILE.gltf|FILE.glb ... \\
        [--size 256] [--spp 128] [--bounces 8] [--environment MAP] [--variants multiggx ggx ggx-vkframe]

For each file:

* vkpath: `vkpath convert FILE -o TMP/scene.toml` writes the scene vkpath makes of the file (the framed
  camera: horizontal `fov`, position, look_at, up; [image]; the file as one [[mesh]]; a uniform white
  [environment] when the file has no lights). A copy gets a [render] section: filter = "box" (a one-pixel
  box, as Cycles' box of width 1) and max_bounces = --bounces. `vkpath render` renders it at --size across
  (the height keeps the converted [image] aspect) with --spp, `--aov variance,depth` (the standard error of
  the mean; finite depth marks the pixels whose every sample met the model), `--environment MAP` if given.
* Cycles (in this process, `import bpy`): factory settings with no objects, `bpy.ops.import_scene.gltf`,
  a camera at the TOML's position / look_at / up / fov converted to Blender's Z-up frame (the importer maps
  glTF (x, y, z) to Blender (x, -z, y): checked here on the framed bounding-sphere centre against the
  imported objects' bounds), the world a Background of (1, 1, 1) strength 1 or the map through an
  Environment Texture rotated to Mitsuba's orientation (below), Cycles on the CPU with the same size and
  spp, box filter width 1, no clamping, Filter Glossy 0, both caustics on, no shadow terminator offset,
  every bounce kind limited alike
  (max_bounces = --bounces - 1: Cycles counts bounces after the first hit's direct light, Blender's "0 =
  direct lighting only", checked on an emitting grey box: 0 gives L = 1 + a for albedo a), no denoising,
  no adaptive sampling, view transform Standard, look None, exposure 0, a linear float EXR.
* Variants of the Cycles side (--variants): `multiggx` is the importer's material as it is (Blender 4+'s
  Principled BSDF defaults to Multiscatter GGX); `ggx` sets every Principled node to single-scattering
  GGX; `ggx-vkframe` is `ggx` with the normal map rebuilt in nodes on vkpath's tangent frame (T = the
  triangle's dp/du made perpendicular to the interpolated normal N, B = N x T turned towards the
  triangle's dp/dv) instead of the MikkTSpace tangents that Blender's Normal Map node uses: the
  difference between `ggx` and `ggx-vkframe` is what the tangent frame alone changes; `ggx-nonormal`
  (not rendered by default) is `ggx` with the normal maps disconnected, what the maps change at all. Each
  variant other than `ggx` is also compared pixel by pixel with the `ggx` image (same seed, so much of the
  noise is shared): the RMS of the luminance difference on the model over its mean.
* Compared: per-channel image means (linear radiance), their ratios Cycles / vkpath, the mean over the
  pixels vkpath's depth marks as the model's (the background, identical in both under a uniform sky,
  dilutes the whole-image ratio), and the ratios of 8x8-pixel block means of the luminance (percentiles
  over the blocks on the model). Side-by-side PNGs go to --png-dir (default /tmp/gltf-check), never the
  repository (vkpath, then each Cycles variant, then the luminance ratio Cycles / vkpath of `multiggx` and
  of `ggx`: grey equal, red Cycles brighter, blue darker, saturating at 25 %); --out writes the markdown
  table (default benches/peers/results/gltf-cycles.md).

The environment map (--environment): vkpath and Mitsuba 3 read an equirectangular map with +y up and u =
atan2(x, -z) / 2 pi (docs/scene-format.md, [environment]). Blender's Environment Texture, in its Z-up
world, reads u = (atan2(d_y, d_x) - pi) / (-2 pi) = 1/2 - phi / 2 pi (Cycles'
direction_to_equirectangular), the top row at +Z. With Blender's d = (x, -z, y) of the glTF direction,
Mitsuba's u = atan2(x, -z) / 2 pi = 1/4 - phi / 2 pi, so Blender must look the map up at phi + 90
degrees: the view direction rotated by +90 degrees about Blender's Z (a Mapping node of type Point).
Checked (2026-12-05) by rendering the bare map in both through 90-degree cameras looking along glTF -z,
+x, +z, +y and one oblique direction: +90 matched (image means within 0.1 %, the pixels within the noise
of 256 spp) and -90, 0, 180 and the mirrored mappings did not (relative RMS 0.6-16). Rows: Mitsuba puts
the first and last rows on the poles (v = j / (H - 1)), Blender at texel centres, a shift of at most half
a row (the view straight up differed by 0.4-0.9 %).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import struct
import tomllib
import warnings
import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

VARIANTS = ("multiggx", "ggx", "ggx-vkframe", "ggx-nonormal")
LUM = (0.2126, 0.7152, 0.0722)


# --------------------------------------------------------------------------------------------------
# vkpath
# --------------------------------------------------------------------------------------------------


def vkpath_scene(vkpath: Path, gltf: Path, tmp: Path, bounces: int) -> tuple[Path, dict]:
    """`vkpath convert` the file into tmp, parse it, and write a copy with the [render] section."""
    converted = tmp / "scene.toml"
    subprocess.run([str(vkpath), "convert", str(gltf), "-o", str(converted)], check=True,
                   stderr=subprocess.DEVNULL)
    text = converted.read_text()
    scene = tomllib.loads(text)
    if "render" in scene:
        raise SystemExit(f"{gltf}: the converted scene has a [render] section already; gltf_check.py adds its own")
    copy = tmp / "scene-box.toml"
    copy.write_text(text + f'\n[render]\nfilter = "box"\nmax_bounces = {bounces}\n')
    return copy, scene


def render_vkpath(vkpath: Path, scene: Path, w: int, h: int, spp: int, seed: int, env: Path | None,
                  out: Path) -> dict:
    """vkpath's render: through its Python module when this venv has it (benches/peers/setup.sh installs
    it), else by running the binary."""
    try:
        import vkpath as vk
    except ImportError:
        return render_vkpath_binary(vkpath, scene, w, h, spp, seed, env, out)
    import numpy as np

    t0 = time.perf_counter()
    s = vk.load(scene)
    s.set_size(w, h)
    if env is not None:
        s.set_environment(env)
    r = s.render(spp=spp, seed=seed, aovs=["variance", "depth"])
    wall = time.perf_counter() - t0
    return {"rgb": np.asarray(r.image, dtype=np.float64), "var": np.asarray(r.aovs["variance"], dtype=np.float64),
            "mask": np.isfinite(r.aovs["depth"]), "wall": wall, "seconds": r.summary["seconds"]}


def render_vkpath_binary(vkpath: Path, scene: Path, w: int, h: int, spp: int, seed: int, env: Path | None,
                         out: Path) -> dict:
    cmd = [str(vkpath), "render", str(scene), "--width", str(w), "--height", str(h), "--spp", str(spp),
           "--seed", str(seed), "--aov", "variance,depth", "-o", str(out), "--json", "--quiet"]
    if env is not None:
        cmd += ["--environment", str(env)]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    info = json.loads(p.stdout)
    import numpy as np
    import OpenEXR

    with OpenEXR.File(str(out)) as f:
        ch = f.channels()
        rgb = np.asarray(ch["RGB"].pixels, dtype=np.float64)
        var = np.asarray(ch["variance"].pixels, dtype=np.float64)
        depth = np.asarray(ch["depth.Z"].pixels if "depth.Z" in ch else ch["depth"].pixels, dtype=np.float64)
    return {"rgb": rgb, "var": var, "mask": np.isfinite(depth), "wall": wall, "seconds": info["seconds"]}


# --------------------------------------------------------------------------------------------------
# Cycles
# --------------------------------------------------------------------------------------------------


def to_blender(v) -> tuple[float, float, float]:
    """glTF / vkpath (x, y, z), y up -> Blender (x, -z, y), z up (the glTF importer's axis conversion)."""
    return (v[0], -v[2], v[1])


def cycles_scene(bpy, gltf: Path, cam: dict, w: int, h: int, spp: int, bounces: int, seed: int,
                 threads: int, env: Path | None) -> dict:
    """A fresh Blender scene with the imported file, the camera, the world and the render settings.
    Returns facts checked on the way (the bounds' centre in glTF coordinates)."""
    import mathutils

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(gltf))
    sc = bpy.context.scene

    # The importer's axis conversion, checked: the centre of the imported meshes' world bounds, mapped
    # back to glTF coordinates, is the centre vkpath framed (camera.look_at).
    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for o in sc.objects:
        if o.type != "MESH":
            continue
        for c in o.bound_box:
            p = o.matrix_world @ mathutils.Vector(c)
            for i in range(3):
                lo[i] = min(lo[i], p[i])
                hi[i] = max(hi[i], p[i])
    centre_b = [(a + b) / 2 for a, b in zip(lo, hi)]
    # Cycles moves shadow rays' origins off smooth-shaded low-poly surfaces by default (the shadow
    # terminator geometry offset, 0.1); a plain path tracer, vkpath, does not. Off here (measured: no change
    # on DamagedHelmet under the map, 1.0161 against 1.0160 in the model's ratio).
    for o in sc.objects:
        if o.type == "MESH":
            o.shadow_terminator_geometry_offset = 0.0
            o.cycles.shadow_terminator_geometry_offset = 0.0
    centre_gltf = (centre_b[0], centre_b[2], -centre_b[1])

    # Camera: Blender's camera looks along its local -Z with +Y up; X = forward x up is the image's right.
    pos = mathutils.Vector(to_blender(cam["position"]))
    fwd = (mathutils.Vector(to_blender(cam["look_at"])) - pos).normalized()
    up = mathutils.Vector(to_blender(cam.get("up", [0.0, 1.0, 0.0])))
    right = fwd.cross(up).normalized()
    up = right.cross(fwd).normalized()
    rot = mathutils.Matrix((right, up, -fwd)).transposed()  # columns: X, Y, Z of the camera
    cd = bpy.data.cameras.new("vkpath camera")
    cd.type = "PERSP"
    cd.sensor_fit = "HORIZONTAL"
    cd.angle = math.radians(cam["fov"])  # with sensor_fit HORIZONTAL: the horizontal field of view
    cd.clip_start = 1e-4
    cd.clip_end = 1e6
    co = bpy.data.objects.new("vkpath camera", cd)
    co.matrix_world = mathutils.Matrix.Translation(pos) @ rot.to_4x4()
    sc.collection.objects.link(co)
    sc.camera = co
    if cam.get("type", "perspective") != "perspective" or cam.get("aperture", 0.0) != 0.0:
        raise SystemExit(f"{gltf}: only pinhole perspective cameras are mapped")

    # World: a uniform white sky (the converted scene's [environment] radiance) or the map.
    world = bpy.data.worlds.new("vkpath environment")
    with warnings.catch_warnings():  # Blender 5 always uses nodes and warns that the switch will go
        warnings.simplefilter("ignore", DeprecationWarning)
        if not getattr(world, "use_nodes", True):
            world.use_nodes = True
    sc.world = world
    nt = world.node_tree
    bg = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground")
    bg.inputs["Strength"].default_value = 1.0
    if env is None:
        bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    else:
        tex = nt.nodes.new("ShaderNodeTexEnvironment")
        tex.image = bpy.data.images.load(str(env))
        tex.image.colorspace_settings.name = "Linear Rec.709"  # the EXR's values as they are
        tex.interpolation = "Linear"
        tex.projection = "EQUIRECTANGULAR"
        coord = nt.nodes.new("ShaderNodeTexCoord")
        mapping = nt.nodes.new("ShaderNodeMapping")
        mapping.vector_type = "POINT"
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(90.0))  # see the docstring
        nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Color"], bg.inputs["Color"])

    r = sc.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = w, h, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.threads_mode = "FIXED"
    r.threads = threads
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    c = sc.cycles
    c.device = "CPU"
    c.samples = spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = seed
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces",
              "transparent_max_bounces"):
        setattr(c, k, bounces - 1)
    vs = sc.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    return {"centre_gltf": centre_gltf}


def set_distribution(bpy, dist: str) -> int:
    n = 0
    for m in bpy.data.materials:
        if m.node_tree is None:
            continue
        for node in m.node_tree.nodes:
            if node.bl_idname == "ShaderNodeBsdfPrincipled":
                node.distribution = dist
                n += 1
    return n


def vkpath_tangent_frame(bpy) -> int:
    """Rebuild every tangent-space Normal Map node feeding a Principled BSDF on vkpath's frame: per-corner
    attributes vk_T = dp/du and vk_V = dp/dv of the corner's triangle (world space, from the UV map the
    node names), then N' = normalize(T' m.x s + B m.y s + N m.z), T' = normalize(T - N (N.T)), B = N x T'
    flipped where it points away from dp/dv, m = 2 t - 1, s = the node's strength (glTF's scale).
    Returns the number of nodes replaced."""
    import numpy as np

    # The attributes, on every mesh (world-space positions, so the vectors are world vectors).
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            continue
        me = o.data
        uv_layer = me.uv_layers.active
        if uv_layer is None:
            continue
        mw = np.array(o.matrix_world)
        co = np.array([v.co for v in me.vertices], dtype=np.float64)
        co = co @ mw[:3, :3].T + mw[:3, 3]
        nl = len(me.loops)
        loop_v = np.empty(nl, dtype=np.int64)
        me.loops.foreach_get("vertex_index", loop_v)
        uv = np.empty(nl * 2, dtype=np.float64)
        uv_layer.data.foreach_get("uv", uv)
        uv = uv.reshape(nl, 2)
        t_attr = np.zeros((nl, 3))
        v_attr = np.zeros((nl, 3))
        for poly in me.polygons:
            ls = list(poly.loop_indices)
            if len(ls) != 3:
                raise SystemExit("ggx-vkframe: a non-triangle face (the glTF importer should give triangles)")
            p0, p1, p2 = co[loop_v[ls]]
            (u0, w0), (u1, w1), (u2, w2) = uv[ls]
            dp1, dp2 = p1 - p0, p2 - p0
            du1, du2, dv1, dv2 = u1 - u0, u2 - u0, w1 - w0, w2 - w0
            det = du1 * dv2 - du2 * dv1
            if abs(det) < 1e-20:
                continue
            t_attr[ls] = (dv2 * dp1 - dv1 * dp2) / det
            v_attr[ls] = (du1 * dp2 - du2 * dp1) / det
        for name, data in (("vk_T", t_attr), ("vk_V", v_attr)):
            if name in me.attributes:
                me.attributes.remove(me.attributes[name])
            a = me.attributes.new(name, "FLOAT_VECTOR", "CORNER")
            a.data.foreach_set("vector", data.astype(np.float32).ravel())

    replaced = 0
    for m in bpy.data.materials:
        nt = m.node_tree
        if nt is None:
            continue
        for nm in [n for n in nt.nodes if n.bl_idname == "ShaderNodeNormalMap"]:
            if nm.space != "TANGENT" or not nm.inputs["Color"].is_linked:
                continue
            color = nm.inputs["Color"].links[0].from_socket
            strength = nm.inputs["Strength"].default_value
            targets = [lk.to_socket for lk in nm.outputs["Normal"].links]

            def node(kind, **props):
                x = nt.nodes.new(kind)
                for k, v in props.items():
                    setattr(x, k, v)
                return x

            def vmath(op, a, b=None):
                x = node("ShaderNodeVectorMath", operation=op)
                nt.links.new(a, x.inputs[0])
                if b is not None:
                    nt.links.new(b, x.inputs[1])
                return x

            geo = node("ShaderNodeNewGeometry")
            n_ = geo.outputs["Normal"]
            at = node("ShaderNodeAttribute", attribute_type="GEOMETRY", attribute_name="vk_T")
            av = node("ShaderNodeAttribute", attribute_type="GEOMETRY", attribute_name="vk_V")
            t = at.outputs["Vector"]
            ndt = vmath("DOT_PRODUCT", n_, t)
            n_scaled = node("ShaderNodeVectorMath", operation="SCALE")
            nt.links.new(n_, n_scaled.inputs[0])
            nt.links.new(ndt.outputs["Value"], n_scaled.inputs["Scale"])
            t_perp = vmath("NORMALIZE", vmath("SUBTRACT", t, n_scaled.outputs[0]).outputs[0]).outputs[0]
            b = vmath("CROSS_PRODUCT", n_, t_perp).outputs[0]
            bdv = vmath("DOT_PRODUCT", b, av.outputs["Vector"])
            sign = node("ShaderNodeMath", operation="SIGN")
            nt.links.new(bdv.outputs["Value"], sign.inputs[0])
            b_signed = node("ShaderNodeVectorMath", operation="SCALE")
            nt.links.new(b, b_signed.inputs[0])
            nt.links.new(sign.outputs[0], b_signed.inputs["Scale"])
            mm = node("ShaderNodeVectorMath", operation="MULTIPLY_ADD")
            nt.links.new(color, mm.inputs[0])
            mm.inputs[1].default_value = (2.0, 2.0, 2.0)
            mm.inputs[2].default_value = (-1.0, -1.0, -1.0)
            sep = node("ShaderNodeSeparateXYZ")
            nt.links.new(mm.outputs[0], sep.inputs[0])

            def scaled(vec_socket, scalar_socket, factor):
                x = node("ShaderNodeVectorMath", operation="SCALE")
                nt.links.new(vec_socket, x.inputs[0])
                if factor == 1.0:
                    nt.links.new(scalar_socket, x.inputs["Scale"])
                else:
                    f = node("ShaderNodeMath", operation="MULTIPLY")
                    nt.links.new(scalar_socket, f.inputs[0])
                    f.inputs[1].default_value = factor
                    nt.links.new(f.outputs[0], x.inputs["Scale"])
                return x.outputs[0]

            sx = scaled(t_perp, sep.outputs["X"], strength)
            sy = scaled(b_signed.outputs[0], sep.outputs["Y"], strength)
            sz = scaled(n_, sep.outputs["Z"], 1.0)
            total = vmath("ADD", vmath("ADD", sx, sy).outputs[0], sz).outputs[0]
            mapped = vmath("NORMALIZE", total).outputs[0]
            for s in targets:
                nt.links.new(mapped, s)
            nt.nodes.remove(nm)
            replaced += 1
    return replaced


def disconnect_normal_maps(bpy) -> int:
    n = 0
    for m in bpy.data.materials:
        if m.node_tree is None:
            continue
        for node in m.node_tree.nodes:
            if node.bl_idname == "ShaderNodeNormalMap":
                for lk in list(node.outputs["Normal"].links):
                    m.node_tree.links.remove(lk)
                    n += 1
    return n


def has_normal_map(bpy) -> bool:
    return any(n.bl_idname == "ShaderNodeNormalMap" for m in bpy.data.materials if m.node_tree
               for n in m.node_tree.nodes)


def render_cycles(bpy, out: Path) -> tuple[object, float]:
    import numpy as np
    import OpenEXR

    bpy.context.scene.render.filepath = str(out)
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    wall = time.perf_counter() - t0
    with OpenEXR.File(str(out)) as f:
        ch = f.channels()
        if "RGBA" in ch:
            img = ch["RGBA"].pixels[..., :3]
        elif "RGB" in ch:
            img = ch["RGB"].pixels
        else:
            img = np.stack([ch[c].pixels for c in "RGB"], axis=-1)
    return np.asarray(img, dtype=np.float64), wall


# --------------------------------------------------------------------------------------------------
# Comparison and pictures
# --------------------------------------------------------------------------------------------------


def block_means(x, b: int):
    h, w = x.shape
    by, bx = h // b, w // b
    return x[: by * b, : bx * b].reshape(by, b, bx, b).mean(axis=(1, 3))


def compare(v: dict, c, block: int) -> dict:
    import numpy as np

    lum = np.array(LUM)
    vm, cm = v["rgb"].reshape(-1, 3).mean(axis=0), c.reshape(-1, 3).mean(axis=0)
    p = v["rgb"].shape[0] * v["rgb"].shape[1]
    se = np.sqrt(v["var"].reshape(-1, 3).sum(axis=0)) / p
    mask = v["mask"]
    # Noise: vkpath's per-pixel variance of the mean (its AOV); the luminance's bounded by (sum_c w_c sd_c)^2
    # (the channels are correlated, as in xml_check.py). Cycles' is taken to be the same, so a difference
    # has sqrt(2) times vkpath's standard error.
    lum_var = (np.sqrt(v["var"]) @ lum) ** 2
    obj_v = (v["rgb"][mask] @ lum).mean() if mask.any() else float("nan")
    obj_se = math.sqrt(2 * lum_var[mask].sum()) / mask.sum() / obj_v if mask.any() else float("nan")
    obj_c = (c[mask] @ lum).mean() if mask.any() else float("nan")
    vb = block_means(v["rgb"] @ lum, block)
    cb = block_means(c @ lum, block)
    on_model = block_means(mask.astype(np.float64), block) > 0.5
    b_sd = np.sqrt(2 * block_means(lum_var, block) / block ** 2) / np.where(vb > 0, vb, np.nan)
    ratios = (cb / np.where(vb > 0, vb, np.nan))[on_model]
    block_noise = float(np.nanmedian(b_sd[on_model])) if on_model.any() else float("nan")
    ratios = ratios[np.isfinite(ratios)]
    pct = np.percentile(ratios, [5, 50, 95]) if ratios.size else [float("nan")] * 3
    within = float((np.abs(ratios - 1) < 0.05).mean()) if ratios.size else float("nan")
    return {"v_mean": vm, "c_mean": cm, "v_se": se, "ratio": cm / vm, "obj_ratio": obj_c / obj_v, "obj_se": obj_se,
            "block_noise": block_noise,
            "blocks": int(ratios.size), "block_pct": list(pct), "within5": within,
            "coverage": float(mask.mean())}


def srgb8(img):
    import numpy as np

    x = np.clip(img, 0.0, 1.0)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (x * 255 + 0.5).astype(np.uint8)


def ratio_picture(c, v):
    """Luminance ratio Cycles / vkpath as colours: grey at 1, red where Cycles is brighter, blue where
    darker, saturating at +-25 %."""
    import numpy as np

    lum = np.array(LUM)
    r = (c @ lum + 1e-6) / (v @ lum + 1e-6)
    t = np.clip((r - 1) / 0.25, -1, 1)
    out = np.empty(r.shape + (3,))
    out[..., 0] = 0.5 + 0.5 * np.clip(t, 0, 1) - 0.5 * np.clip(-t, 0, 1)
    out[..., 2] = 0.5 + 0.5 * np.clip(-t, 0, 1) - 0.5 * np.clip(t, 0, 1)
    out[..., 1] = 0.5 - 0.5 * np.abs(t)
    return (out * 255 + 0.5).astype(np.uint8)


def write_png(path: Path, rgb8) -> None:
    h, w, _ = rgb8.shape
    raw = b"".join(b"\x00" + rgb8[y].tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


# --------------------------------------------------------------------------------------------------


def git_commit() -> str:
    p = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                           capture_output=True, text=True).stdout.strip()
    return p.stdout.strip() + ("+dirty" if dirty else "")


def rel(path: Path) -> str:
    """A path as the repository's docs write it: relative to the repository root where it can be."""
    try:
        return os.path.relpath(path.resolve(), ROOT)
    except ValueError:
        return str(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", type=Path, nargs="+", help="glTF files (.gltf or .glb)")
    ap.add_argument("--size", type=int, default=256, help="image width (the height keeps the converted aspect)")
    ap.add_argument("--spp", type=int, default=128, help="samples per pixel, both renderers")
    ap.add_argument("--bounces", type=int, default=8,
                    help="vkpath's max_bounces (scattering events); Cycles gets one less (its count)")
    ap.add_argument("--environment", type=Path, default=None, help="equirectangular map (Mitsuba's orientation)")
    ap.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS[:3]),
                    help="Cycles material variants to render (ggx-vkframe and ggx-nonormal only where a "
                         "normal map is)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--block", type=int, default=8)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="Cycles' CPU threads")
    default_vkpath = ROOT / "target" / "release" / "vkpath"
    ap.add_argument("--vkpath", type=Path, default=default_vkpath)
    ap.add_argument("--vkpath-label", default=None,
                    help="the vkpath build the table names (default: the checkout's `git rev-parse --short "
                         "HEAD`, +dirty with uncommitted changes); give it when --vkpath is a copy of another "
                         "build")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "gltf-cycles.md",
                    help="markdown table ('-' for none)")
    ap.add_argument("--append", action="store_true", help="append to --out instead of replacing it")
    ap.add_argument("--png-dir", type=Path, default=Path(tempfile.gettempdir()) / "gltf-check")
    a = ap.parse_args()

    import numpy as np
    import bpy
    import addon_utils

    from compare import vkpath_driver

    addon_utils.enable("io_scene_gltf2", default_set=True)
    a.png_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="gltf-check-") as tmpd:
        tmp = Path(tmpd)
        for f in a.files:
            f = f.resolve()
            name = f.stem
            work = tmp / name
            work.mkdir()
            scene_toml, scene = vkpath_scene(a.vkpath, f, work, a.bounces)
            cam, img = scene["camera"], scene.get("image", {})
            iw, ih = img.get("width", 512), img.get("height", 512)
            w, h = a.size, max(1, round(a.size * ih / iw))
            env_radiance = scene.get("environment", {}).get("radiance")
            if a.environment is None and env_radiance != [1.0, 1.0, 1.0]:
                raise SystemExit(f"{f}: the converted scene's environment is {scene.get('environment')}, "
                                 f"not the uniform white sky this check maps")
            if scene.get("light"):
                raise SystemExit(f"{f}: has lights; gltf_check.py maps only the unlit case")
            print(f"{name}: {w}x{h}, {a.spp} spp, vkpath max_bounces {a.bounces} / Cycles {a.bounces - 1}"
                  f"{', environment ' + a.environment.name if a.environment else ', uniform white sky'}",
                  flush=True)
            v = render_vkpath(a.vkpath, scene_toml, w, h, a.spp, a.seed, a.environment, work / "vkpath.exr")
            print(f"  vkpath: mean {np.round(v['rgb'].reshape(-1, 3).mean(axis=0), 5)}  ({v['wall']:.1f} s wall, "
                  f"{v['seconds']:.1f} s rendering)", flush=True)
            pictures = [srgb8(v["rgb"])]
            results = {}
            images = {}
            ratio_pictures = []
            for variant in a.variants:
                facts = cycles_scene(bpy, f, cam, w, h, a.spp, a.bounces, a.seed, a.threads, a.environment)
                dc = np.array(facts["centre_gltf"]) - np.array(cam["look_at"])
                if np.abs(dc).max() > 1e-3 * max(1.0, np.abs(cam["look_at"]).max()):
                    raise SystemExit(f"{f}: the imported bounds' centre {facts['centre_gltf']} (back in glTF "
                                     f"coordinates) is not vkpath's framed centre {cam['look_at']}")
                if variant in ("ggx-vkframe", "ggx-nonormal") and not has_normal_map(bpy):
                    continue
                n = set_distribution(bpy, "MULTI_GGX" if variant == "multiggx" else "GGX")
                if variant == "ggx-vkframe":
                    replaced = vkpath_tangent_frame(bpy)
                    print(f"  (ggx-vkframe: {replaced} Normal Map node(s) rebuilt on vkpath's tangent frame)")
                if variant == "ggx-nonormal":
                    print(f"  (ggx-nonormal: {disconnect_normal_maps(bpy)} Normal Map link(s) removed)")
                c, wall = render_cycles(bpy, work / f"cycles-{variant}.exr")
                cmp = compare(v, c, a.block)
                results[variant] = (cmp, wall)
                images[variant] = c
                pictures += [srgb8(c)]
                print(f"  Cycles {variant} ({n} Principled nodes): mean {np.round(cmp['c_mean'], 5)}  ratio "
                      f"{np.round(cmp['ratio'], 4)}  model pixels {cmp['obj_ratio']:.4f} +- {cmp['obj_se']:.4f}  blocks "
                      f"p5/p50/p95 {np.round(cmp['block_pct'], 3)} (noise sd of one block's ratio ~"
                      f"{cmp['block_noise']:.3f})  ({wall:.1f} s wall)", flush=True)
                if variant in ("multiggx", "ggx"):
                    ratio_pictures.append(ratio_picture(c, v["rgb"]))
            if "ggx" in images:
                for variant, c in images.items():
                    if variant != "ggx":
                        d = ((c - images["ggx"]) @ np.array(LUM))[v["mask"]]
                        base = (images["ggx"] @ np.array(LUM))[v["mask"]].mean()
                        results[variant][0]["vs_ggx"] = float(np.sqrt((d ** 2).mean()) / base)
                        print(f"  Cycles {variant} vs Cycles ggx, pixel by pixel on the model: relative RMS "
                              f"difference {results[variant][0]['vs_ggx']:.4f}, mean ratio "
                              f"{results[variant][0]['obj_ratio'] / results['ggx'][0]['obj_ratio']:.4f}")
            # The pictures cropped to the model (its bounds in vkpath's depth, 4 pixels around) and enlarged
            # (nearest) to at least 256 rows, so that the differences can be seen.
            ys, xs = np.nonzero(v["mask"]) if v["mask"].any() else (np.array([0, h - 1]), np.array([0, w - 1]))
            y0, y1 = max(0, ys.min() - 4), min(h, ys.max() + 5)
            x0, x1 = max(0, xs.min() - 4), min(w, xs.max() + 5)
            k = max(1, math.ceil(256 / (y1 - y0)))
            crop = [np.repeat(np.repeat(p[y0:y1, x0:x1], k, axis=0), k, axis=1)
                    for p in pictures + ratio_pictures]
            gap = np.full((crop[0].shape[0], 4, 3), 255, dtype=np.uint8)
            strip = [crop[0]]
            for p in crop[1:]:
                strip += [gap, p]
            png = a.png_dir / f"{name}{'-env' if a.environment else ''}.png"
            write_png(png, np.concatenate(strip, axis=1))
            shown = [x for x in ("multiggx", "ggx") if x in results]
            print(f"  side by side: {png} (vkpath, then Cycles {', '.join(results)}, then the luminance ratio "
                  f"Cycles / vkpath of {' and '.join(shown) or 'none'}: red brighter, blue darker, saturating at "
                  f"25 %)")
            rows.append((name, w, h, v, results))

    if str(a.out) == "-":
        return 0
    bpy_version = bpy.app.version_string
    env_text = rel(a.environment) if a.environment else "uniform white sky (radiance 1)"
    lines = []
    if not a.append or not a.out.exists():
        lines += ["# glTF files: vkpath and Blender's Cycles", "",
                  "Written by `benches/peers/gltf_check.py` (the method and the findings are in "
                  "benches/peers/README.md, \"glTF files: Blender's Cycles\").", ""]
    lines += [f"## {_dt.date.today().isoformat()}: {', '.join(r[0] for r in rows)}; {env_text}", "",
              f"vkpath {a.vkpath_label or git_commit()} on {vkpath_driver(a.vkpath)}; bpy {bpy_version} (Cycles, CPU, "
              f"{a.threads} threads); {platform.machine()}, {os.cpu_count()} cores. {a.spp} spp, box filter, "
              f"vkpath max_bounces {a.bounces} = Cycles max_bounces {a.bounces - 1}, seed {a.seed}. Means are "
              f"linear radiance over the whole image (+- vkpath's standard error); ratios Cycles / vkpath; "
              f"\"model\" = the luminance over the pixels vkpath's depth AOV marks as wholly on the model (+- the "
              f"difference's standard error, sqrt 2 times vkpath's, Cycles' noise taken as equal); "
              f"blocks = {a.block}x{a.block}-pixel luminance ratios on the model (5th, 50th, 95th percentile; "
              f"share within 5 %; noise = the median standard deviation of one block's ratio from noise alone); vs ggx = the RMS of the per-pixel luminance difference from the Cycles `ggx` "
              f"image (same seed) over its mean, on the model. Seconds: wall time of each render (vkpath's command, load and kernel "
              f"compilation included; Cycles' render call, BVH build and image loading included).", "",
              "| file | size | renderer | mean R | mean G | mean B | ratio R | ratio G | ratio B | model | "
              "blocks p5 / p50 / p95 | within 5 % | vs ggx | s |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, w, h, v, results in rows:
        vm = v["rgb"].reshape(-1, 3).mean(axis=0)
        se = np.sqrt(v["var"].reshape(-1, 3).sum(axis=0)) / (w * h)
        lines.append(f"| {name} | {w}x{h} | vkpath | " + " | ".join(f"{m:.4f} +- {s:.4f}" for m, s in zip(vm, se))
                     + f" | | | | | | | | {v['wall']:.1f} |")
        for variant, (cmp, wall) in results.items():
            pct = " / ".join(f"{x:.3f}" for x in cmp["block_pct"])
            lines.append(f"| {name} | {w}x{h} | Cycles {variant} | " + " | ".join(f"{m:.4f}" for m in cmp["c_mean"])
                         + " | " + " | ".join(f"{r:.4f}" for r in cmp["ratio"])
                         + f" | {cmp['obj_ratio']:.4f} +- {cmp['obj_se']:.4f} | {pct} (noise ~{cmp['block_noise']:.3f}) | {cmp['within5'] * 100:.0f} % | "
                         + (f"{cmp['vs_ggx']:.4f}" if "vs_ggx" in cmp else "") + f" | {wall:.1f} |")
    lines.append("")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    with open(a.out, "a" if a.append else "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(f"wrote {rel(a.out)}")
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    raise SystemExit(main())
