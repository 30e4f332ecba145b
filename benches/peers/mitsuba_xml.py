"""A Mitsuba XML scene as both renderers take it in compare.py: each reads, with its own importer, a copy
of the file in which only what the comparison fixes is changed: the film's size, the sampler's type (for
Mitsuba's ladders), the integrator's `rr_depth` (Mitsuba's default is 5, vkpath's `--roulette-depth` 3),
a custom default integrator (`<default name="integrator">`, which Bitterli's exports set to their own
plugin; Mitsuba's command line overrides it with `-D integrator=path`) set to `path`, the reconstruction
filter set to `box` unless the file's is asked for, and file names made absolute (the copy lives in the
comparison's tmp/ folder). The camera, `max_depth`, the materials and the meshes are the file's. Includes are inlined (the film may be in one).
The original is never written.

Why the filter: Mitsuba's film splats each sample into every pixel its filter covers (a tent of radius 1
covers four). vkpath does the same for these files (`render.splat`, on by default for a tent or Gaussian
with `sample_border = false`); with `--splat off`, or with `sample_border = true`, it importance-samples
the filter and puts each sample into one pixel (pbrt-v4's way), whose per-pixel error at equal spp is
about twice as large (Bitterli's Cornell box, 512x512, 64 spp: 18.8 % against Mitsuba's 9.4 %). With a
box filter of one pixel both put each sample into one pixel, as for the TOML scenes: the default here,
so that the samplers and the speed are compared alone; `--xml-filter file` keeps the files' filters.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path


def _defaults(root: ET.Element) -> dict[str, str]:
    out: dict[str, str] = {}
    for d in root.iter("default"):
        out.setdefault(d.get("name", ""), d.get("value", ""))
    return out


def _resolve(value: str, defaults: dict[str, str]) -> str:
    # Longest names first, as Mitsuba substitutes them.
    for name in sorted(defaults, key=len, reverse=True):
        value = value.replace("$" + name, defaults[name])
    return value


def _film(root: ET.Element) -> ET.Element:
    film = root.find("sensor/film")
    if film is None:
        raise ValueError("no <sensor><film>: the comparison needs the film's size")
    return film


def _named(parent: ET.Element, tag: str, *names: str) -> ET.Element | None:
    """The first child <tag name="..."> with one of the names (an Element without children is falsy, so
    callers compare with None)."""
    for e in parent.findall(tag):
        if e.get("name") in names:
            return e
    return None


def _inlined(path: Path, main: Path | None = None, depth: int = 0) -> ET.Element:
    """The file's root with every `<include>` replaced by the included file's elements (recursively) and
    every `filename` made absolute: one self-contained scene, whatever folder the copy is written to.
    Relative names resolve from the main file's folder, as Mitsuba's file resolver does (Mitsuba's own
    fragments/shapes.xml names `meshes/...` beside the main file), else from the including file's."""
    if depth > 16:
        raise ValueError(f"{path}: includes nested more than 16 deep")
    main = main or path.resolve().parent
    own = path.resolve().parent

    def resolve(name: str) -> str:
        first = main / name
        return str(first if first.exists() or not (own / name).exists() else own / name)

    root = ET.parse(path).getroot()
    for e in root.iter("string"):
        if e.get("name") == "filename" and "$" not in e.get("value", ""):
            e.set("value", resolve(e.get("value")))

    def expand(parent: ET.Element) -> None:
        for i, child in reversed(list(enumerate(parent))):
            if child.tag == "include" and "filename" in child.attrib:
                included = _inlined(Path(resolve(child.get("filename"))), main, depth + 1)
                # A file whose root is not a <scene> is one element (Mitsuba's rule).
                parts = list(included) if included.tag == "scene" else [included]
                parent.remove(child)
                for k, part in enumerate(parts):
                    parent.insert(i + k, part)
            else:
                expand(child)

    expand(root)
    return root


def film_size(path: Path) -> tuple[int, int]:
    """The film's width and height as the file gives them (`$resx` resolved by its `<default>`s;
    Mitsuba's default 768x576 for a missing one)."""
    root = _inlined(path)
    defaults = _defaults(root)
    film = _film(root)
    size = []
    for name, default in (("width", 768), ("height", 576)):
        e = _named(film, "integer", name)
        size.append(int(_resolve(e.get("value"), defaults)) if e is not None else default)
    return size[0], size[1]


def custom_integrator(path: Path) -> bool:
    """Whether the file's integrator is given by a `<default name="integrator">` (Bitterli's exports name a
    custom plugin there, which Mitsuba's command line overrides with `-D integrator=path`)."""
    return "integrator" in _defaults(_inlined(path))


def max_depth(path: Path) -> int:
    """The integrator's max_depth (-1, Mitsuba's default, when absent)."""
    root = _inlined(path)
    integrator = root.find("integrator")
    if integrator is None:
        return -1
    e = _named(integrator, "integer", "max_depth", "maxDepth")
    return int(_resolve(e.get("value"), _defaults(root))) if e is not None else -1


def copy(path: Path, out: Path, width: int, height: int, sampler: str, rr_depth: int, box: bool) -> Path:
    """Writes the copy the renderers read (see the module comment) to `out` and returns it; `box`: the
    filter becomes a one-pixel box."""
    tree = ET.ElementTree(_inlined(path))
    root = tree.getroot()
    for d in root.iter("default"):
        if d.get("name") == "integrator":
            d.set("value", "path")
    integrator = root.find("integrator")
    if integrator is None:
        integrator = ET.SubElement(root, "integrator", {"type": "path"})
    rr = _named(integrator, "integer", "rr_depth", "rrDepth")
    if rr is None:
        rr = ET.SubElement(integrator, "integer", {"name": "rr_depth"})
    rr.set("value", str(rr_depth))
    film = _film(root)
    # Mitsuba 0.5/0.6 film parameters Mitsuba 3 refuses (Bitterli's living room gives them; vkpath reads
    # them in a 0.x file): the copy drops them, changing nothing in the image but the 0.x logo, except
    # high_quality_edges, which is Mitsuba 3's sample_border (samples beyond the image's edges, so that
    # the edge pixels' filters are whole) and becomes it, as vkpath reads it.
    for e in list(film):
        if e.get("name") in ("high_quality_edges", "highQualityEdges"):
            e.set("name", "sample_border")
        elif e.get("name") in ("banner", "attach_log", "attachLog"):
            film.remove(e)
    for name, value in (("width", width), ("height", height)):
        e = _named(film, "integer", name)
        if e is None:
            e = ET.SubElement(film, "integer", {"name": name})
        e.set("value", str(value))
    if box:
        for f in film.findall("rfilter"):
            film.remove(f)
        ET.SubElement(film, "rfilter", {"type": "box"})
    sensor = root.find("sensor")
    s = sensor.find("sampler")
    if s is None:
        s = ET.SubElement(sensor, "sampler")
    s.set("type", sampler)
    out.parent.mkdir(parents=True, exist_ok=True)
    tree.write(out, encoding="unicode", xml_declaration=False)
    return out


