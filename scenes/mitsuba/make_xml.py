#!/usr/bin/env python3
"""Writes the course's scenes as Mitsuba 3 XML files (scenes/mitsuba/*.xml), for the round trip that
tests/mitsuba.rs checks: each file, read by vkpath, must render the same bits as the TOML scene it came from
(with the box filter, which the Mitsuba translation needs).

The files are Mitsuba's own: benches/peers/mitsuba_scene.py builds Mitsuba's scene dict for each scene (the
translation benches/peers/compare.py uses), Mitsuba 3's `mitsuba.python.xml.dict_to_xml` writes it, and
Mitsuba loads the result (checked here). One edit: dict_to_xml writes a sensor's to_world as decomposed
rotations (`rotate x 180.000005`, ...) and every number with 6 decimals, which moves the camera by the last
bits of a float; the sensor's transform is replaced by Mitsuba's own `<lookat>` with the scene's camera
values written exactly, which Mitsuba reads the same way; and a sphere light's radiance is written as
the f32 that vkpath's upload computes from its power (src/kernel/upload.rs: color * (P / (4 pi pi r r)),
in f32), rather than rounded to 6 decimals.

    benches/peers/setup.sh                                        # the venv with Mitsuba 3.6.4
    benches/peers/.venv/bin/python scenes/mitsuba/make_xml.py    # from the repository root
"""

import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "scenes" / "mitsuba"
SCENES = ["01-sphere", "02-lambert", "03-shadows", "04-gamma", "05-mirror", "06-glass", "07-indirect",
          "08-samples", "09-antialiasing", "10-soft-shadows", "11-depth-of-field", "12-triangle", "course",
          "cornell-box"]


def exact(x: float) -> str:
    """A number with every bit: Python's repr of the float, which reads back as the same double."""
    return repr(float(x))


def lookat_transform(cam: dict) -> str:
    v = lambda a: ", ".join(exact(c) for c in a)  # noqa: E731
    return (f'<transform name="to_world">\n\t\t\t<lookat origin="{v(cam["position"])}" '
            f'target="{v(cam["look_at"])}" up="{v(cam["up"])}"/>\n\t\t</transform>')


def sphere_light_radiance(light: dict):
    """Le as vkpath's upload computes it, in f32 arithmetic, left to right."""
    import numpy as np

    f = np.float32
    pi = f(np.pi)
    scale = f(light["power"]) / (f(4.0) * pi * pi * f(light["radius"]) * f(light["radius"]))
    return [f(c) * scale for c in light["color"]]


def exact_sphere_lights(text: str, lights: list) -> str:
    """Rewrites each sphere light's radiance (shape id light-K) with every bit of its f32 value."""
    for k, light in enumerate(lights):
        if light["type"] != "sphere":
            continue
        le = " ".join(exact(c) for c in sphere_light_radiance(light))
        block = re.search(rf'<shape type="sphere" id="light-{k}".*?</shape>', text, re.S)
        fixed = re.sub(r'<rgb value="[^"]*" name="radiance"/>', f'<rgb value="{le}" name="radiance"/>',
                       block.group(0), count=1)
        text = text[:block.start()] + fixed + text[block.end():]
    return text


def main() -> int:
    sys.path.insert(0, str(ROOT / "benches" / "peers"))
    import mitsuba_scene as ms
    from compare import import_mitsuba  # Dr.Jit's LLVM, as compare.py sets it up

    _, mi, _ = import_mitsuba()
    from mitsuba.python.xml import dict_to_xml

    for name in SCENES:
        toml = ROOT / "scenes" / f"{name}.toml"
        raw = ms.with_overrides(ms.load_toml(toml), toml.parent, filter="box")
        cam = ms.resolved(raw)["camera"]
        spp = ms.resolved(raw)["render"]["samples"]
        with tempfile.TemporaryDirectory() as tmp:
            scene = ms.mitsuba_dict(mi, raw, spp=spp, tmp_dir=tmp)
            xml = Path(tmp) / f"{name}.xml"
            dict_to_xml(scene, str(xml))
            text = xml.read_text()
            # The sensor's to_world (the first transform in the file, inside <sensor>).
            sensor = re.search(r"<sensor\b.*?</sensor>", text, re.S)
            fixed = re.sub(r'<transform name="to_world">.*?</transform>', lookat_transform(cam),
                           sensor.group(0), count=1, flags=re.S)
            text = text[:sensor.start()] + fixed + text[sensor.end():]
            text = exact_sphere_lights(text, ms.resolved(raw)["light"])
            # dict_to_xml copies the meshes to meshes/ beside the file, named per scene (triangles-0.obj,
            # ...): each scene's go to meshes/<scene>/, and the file names them there.
            text = text.replace('value="meshes/', f'value="meshes/{name}/')
            target = OUT / f"{name}.xml"
            target.write_text(text)
            meshes = Path(tmp) / "meshes"
            for f in sorted(meshes.iterdir()) if meshes.is_dir() else []:
                (OUT / "meshes" / name).mkdir(parents=True, exist_ok=True)
                shutil.copy(f, OUT / "meshes" / name / f.name)
        # Mitsuba reads the file it wrote, lookat included, and renders it (small: a check, not a
        # comparison; benches/peers/compare.py compares images).
        import numpy as np

        small = mi.load_file(str(target), resx=32, resy=32, spp=4)
        mean = np.array(mi.render(small), dtype=np.float64).mean()
        if not (np.isfinite(mean) and mean > 0.0):
            raise SystemExit(f"make_xml.py: Mitsuba rendered {target.name} black or not finite ({mean})")
        print(f"wrote {target.relative_to(ROOT)} (Mitsuba renders it: mean {mean:.4f} at 32x32, 4 spp)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
