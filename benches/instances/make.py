#!/usr/bin/env python3
"""Writes the instancing benchmark's scenes (docs/performance.md, "Instances") into a folder.

    python3 benches/instances/make.py OUT_DIR

ball.obj: an icosphere subdivided 5 times (20,480 triangles). gridN-shared.toml: N x N balls on a floor
under a sun, each an [[instance]] of one named [[mesh]] (which itself sits out of view); gridN-copies.toml:
the same balls as N x N [[mesh]] tables; nofloor-*: grid 10 without the floor; painted10-*: grid 10 with
each ball in one of four materials (an [[instance]] in a material of its own, or a [[mesh]] table).
balls.gltf: the 10 x 10 balls as glTF nodes that share one mesh, balls-flat.gltf: the same nodes each
naming its own copy of the mesh (which the reader flattens), each placed by gltf10-shared.toml and
gltf10-flat.toml. Then, for example:

    vkpath bench throughput OUT_DIR/grid10-copies.toml OUT_DIR/grid10-shared.toml --width 256 --height 256 --spp 8 --runs 3
"""
import json
import math
import os
import struct
import sys


def icosphere(subdivisions):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
         (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        middle = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                p = [(v[a][i] + v[b][i]) / 2 for i in range(3)]
                length = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / length for x in p))
                middle[key] = len(v) - 1
            return middle[key]

        refined = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            refined += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = refined
    return v, f


HEAD = '''[camera]
position = [0, 60, 80]
look_at = [0, 0, 0]
fov = 60
[image]
width = 512
height = 512
[render]
max_bounces = 3
[materials]
white = { type = "diffuse", albedo = [0.7, 0.7, 0.7] }
red = { type = "diffuse", albedo = [0.7, 0.1, 0.1] }
green = { type = "diffuse", albedo = [0.1, 0.7, 0.1] }
blue = { type = "diffuse", albedo = [0.1, 0.1, 0.7] }
gold = { type = "conductor", preset = "gold", roughness = 0.3 }
floor = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
[[light]]
type = "directional"
direction = [-0.3, -1, -0.4]
irradiance = 3.0
'''

FLOOR = '''[[triangle]]
vertices = [[-500, -1, -500], [500, -1, 500], [500, -1, -500]]
material = "floor"
[[triangle]]
vertices = [[-500, -1, -500], [-500, -1, 500], [500, -1, 500]]
material = "floor"
'''


def grid(n, shared, floor, painted=False):
    s = HEAD + (FLOOR if floor else "")
    # The named mesh the instances place (drawn itself, out of view).
    s += '[[mesh]]\nobj = "ball.obj"\nname = "ball"\nmaterial = "white"\ntranslate = [0, 0, -5000]\n'
    step = 100.0 / n
    for i in range(n):
        for j in range(n):
            x, z, r = -50 + step * (i + 0.5), -50 + step * (j + 0.5), step * 0.4
            place = f'scale = {r}\ntranslate = [{x}, {r - 1}, {z}]\n'
            colour = ("red", "green", "blue", "gold")[(i + j) % 4] if painted else "white"
            own = f'material = "{colour}"\n' if painted else ""
            if shared:
                s += f'[[instance]]\nmesh = "ball"\n{own}{place}'
            else:
                s += f'[[mesh]]\nobj = "ball.obj"\nmaterial = "{colour}"\n{place}'
    return s


def gltf(v, f, n, shared):
    """A glTF of n x n nodes placing the ball, as grid() places it: one mesh they share, or a copy each."""
    positions = struct.pack("<%df" % (3 * len(v)), *[c for p in v for c in p])
    indices = struct.pack("<%dI" % (3 * len(f)), *[i for t in f for i in t])
    lo = [min(p[i] for p in v) for i in range(3)]
    hi = [max(p[i] for p in v) for i in range(3)]
    step = 100.0 / n
    nodes = []
    for i in range(n):
        for j in range(n):
            x, z, r = -50 + step * (i + 0.5), -50 + step * (j + 0.5), step * 0.4
            nodes.append({"mesh": 0 if shared else len(nodes), "scale": [r, r, r],
                          "translation": [x, r - 1, z]})
    mesh = {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 0}, "indices": 1}]}
    doc = {
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": [mesh] * (1 if shared else len(nodes)),
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5125, "count": 3 * len(f), "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions)},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices)},
        ],
        "buffers": [{"uri": "ball.bin", "byteLength": len(positions) + len(indices)}],
    }
    return json.dumps(doc), positions + indices


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    v, f = icosphere(5)
    with open(os.path.join(out, "ball.obj"), "w") as o:
        o.writelines("v %.7f %.7f %.7f\n" % p for p in v)
        o.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in f)
    scenes = {
        "grid10-shared": grid(10, True, True),
        "grid10-copies": grid(10, False, True),
        "nofloor-shared": grid(10, True, False),
        "nofloor-copies": grid(10, False, False),
        "grid100-shared": grid(100, True, True),
        "painted10-shared": grid(10, True, True, True),
        "painted10-copies": grid(10, False, True, True),
    }
    # The unit ball's normals are its positions (NORMAL shares their accessor).
    for name, shared in (("balls", True), ("balls-flat", False)):
        text, data = gltf(v, f, 10, shared)
        with open(os.path.join(out, name + ".gltf"), "w") as o:
            o.write(text)
        with open(os.path.join(out, "ball.bin"), "wb") as o:
            o.write(data)
        scenes["gltf10-" + ("shared" if shared else "flat")] = (
            HEAD + FLOOR + f'[[mesh]]\nobj = "{name}.gltf"\nmaterial = "white"\n')
    for name, text in scenes.items():
        with open(os.path.join(out, name + ".toml"), "w") as o:
            o.write(text)


if __name__ == "__main__":
    main()
