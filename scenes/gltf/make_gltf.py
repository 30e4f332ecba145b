#!/usr/bin/env python3
"""Writes scenes/gltf/materials.gltf and materials.bin: a glTF 2.0 scene for vkpath's gallery.

A floor, a row of five UV spheres whose glTF metallic-roughness materials step from a rough dielectric to a
polished metal, a small emissive sphere (emissiveFactor x KHR_materials_emissive_strength), a camera and two
KHR_lights_punctual lights (a sun and a point light). Standard library only; run from anywhere:

    python3 scenes/gltf/make_gltf.py
    vkpath render scenes/gltf/materials.gltf -o materials.png
"""

import json
import math
import struct
from pathlib import Path

HERE = Path(__file__).resolve().parent


def uv_sphere(rings=24, segments=48):
    """Positions, normals (the same, unit sphere), uvs and triangle indices of a UV sphere."""
    pos, uv, idx = [], [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            pos.append((math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)))
            uv.append((j / segments, i / rings))
    for i in range(rings):
        for j in range(segments):
            a = i * (segments + 1) + j
            b = a + segments + 1
            # Counter-clockwise seen from outside.
            idx += [a, a + 1, b, a + 1, b + 1, b]
    return pos, pos, uv, idx


def main():
    blob = bytearray()
    views, accessors = [], []

    def add(data, fmt, count, kind, component, minmax=None):
        while len(blob) % 4:
            blob.append(0)
        offset = len(blob)
        for item in data:
            blob.extend(struct.pack("<" + fmt, *(item if isinstance(item, tuple) else (item,))))
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob) - offset})
        acc = {"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        return len(accessors) - 1

    F32, U32 = 5126, 5125
    pos, nrm, uv, idx = uv_sphere()
    sphere = {
        "POSITION": add(pos, "3f", len(pos), "VEC3", F32, ([-1, -1, -1], [1, 1, 1])),
        "NORMAL": add(nrm, "3f", len(nrm), "VEC3", F32),
        "TEXCOORD_0": add(uv, "2f", len(uv), "VEC2", F32),
    }
    sphere_idx = add(idx, "I", len(idx), "SCALAR", U32)
    floor_pos = [(-20, 0, -20), (20, 0, -20), (20, 0, 20), (-20, 0, 20)]
    floor = {
        "POSITION": add(floor_pos, "3f", 4, "VEC3", F32, ([-20, 0, -20], [20, 0, 20])),
        "NORMAL": add([(0, 1, 0)] * 4, "3f", 4, "VEC3", F32),
        "TEXCOORD_0": add([(0, 0), (1, 0), (1, 1), (0, 1)], "2f", 4, "VEC2", F32),
    }
    floor_idx = add([0, 2, 1, 0, 3, 2], "I", 6, "SCALAR", U32)

    # Five balls: (base colour, metallic, roughness), rough dielectric to polished metal.
    balls = [
        ([0.80, 0.20, 0.15], 0.0, 0.9),
        ([0.80, 0.55, 0.15], 0.0, 0.4),
        ([0.20, 0.45, 0.80], 0.0, 0.1),
        ([0.95, 0.75, 0.35], 1.0, 0.4),
        ([0.95, 0.95, 0.95], 1.0, 0.1),
    ]
    materials = [{"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1],
                                                            "metallicFactor": 0.0, "roughnessFactor": 0.8}}]
    meshes = [{"name": "floor", "primitives": [{"attributes": floor, "indices": floor_idx, "material": 0}]}]
    nodes = [{"name": "floor", "mesh": 0}]
    for k, (color, metallic, roughness) in enumerate(balls):
        materials.append({"name": f"ball{k}", "pbrMetallicRoughness": {
            "baseColorFactor": color + [1], "metallicFactor": metallic, "roughnessFactor": roughness}})
        meshes.append({"name": f"ball{k}", "primitives": [
            {"attributes": sphere, "indices": sphere_idx, "material": len(materials) - 1}]})
        nodes.append({"name": f"ball{k}", "mesh": len(meshes) - 1, "translation": [-4.4 + 2.2 * k, 1, 0]})
    materials.append({"name": "glow", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
                      "emissiveFactor": [1.0, 0.6, 0.3],
                      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}}})
    meshes.append({"name": "glow", "primitives": [
        {"attributes": sphere, "indices": sphere_idx, "material": len(materials) - 1}]})
    nodes.append({"name": "glow", "mesh": len(meshes) - 1, "translation": [0, 0.35, 2.2],
                  "scale": [0.35, 0.35, 0.35]})
    # The camera looks at (0, 0.8, 0) from (0, 3, 13): a rotation about x by atan(2.2 / 13), downwards.
    pitch = -math.atan2(2.2, 13.0)
    nodes.append({"name": "camera", "camera": 0, "translation": [0, 3, 13],
                  "rotation": [math.sin(pitch / 2), 0, 0, math.cos(pitch / 2)]})
    # The sun shines along its node's -z: turned to come from the upper left, behind the camera.
    sun = [-0.30, 0.35, 0.10]
    norm = math.sqrt(1 - sum(c * c for c in sun))
    nodes.append({"name": "sun", "rotation": sun + [norm],
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    nodes.append({"name": "lamp", "translation": [3, 3, 3],
                  "extensions": {"KHR_lights_punctual": {"light": 1}}})
    doc = {
        "asset": {"version": "2.0", "generator": "vkpath scenes/gltf/make_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "color": [1.0, 0.95, 0.9], "intensity": 2.5},
            {"type": "point", "color": [0.6, 0.8, 1.0], "intensity": 15.0}]}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 16 / 9, "znear": 0.1}}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": "materials.bin", "byteLength": len(blob)}],
    }
    (HERE / "materials.bin").write_bytes(bytes(blob))
    (HERE / "materials.gltf").write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {HERE / 'materials.gltf'} ({len(blob)} bytes of buffer)")


if __name__ == "__main__":
    main()
