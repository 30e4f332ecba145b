"""vkpath from Python: load a scene, render it into NumPy arrays, edit it, render again.

    import vkpath
    scene = vkpath.load("scenes/course.toml")
    result = scene.render(spp=64, seed=1)
    image = result.image            # H x W x 3 float32, linear radiance
    vkpath.write("course.png", image, scene=scene)

The renders are the command line's (`vkpath render`): the same scene and seed give the same bits. The
GIL is released while the device renders; Ctrl-C stops the render after the pass in flight and returns
what was sampled. Bad input raises ValueError with vkpath's message, which names the file, the line and
the key. docs/python.md is the guide.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Iterable, Mapping, Optional, Union

import numpy as np

from . import _vkpath

__version__ = _vkpath.__version__
__all__ = ["Scene", "Result", "load", "load_dict", "write", "compare", "read", "kernels_compiled"]

PathLike = Union[str, "os.PathLike[str]"]

# The EXR channel names of each layer (`vkpath render --aov`), in the order the layer's array holds them.
_LAYERS = {
    "variance": ("variance.R", "variance.G", "variance.B"),
    "spp": ("spp.Y",),
    "albedo": ("albedo.R", "albedo.G", "albedo.B"),
    "normal": ("normal.X", "normal.Y", "normal.Z"),
    "depth": ("depth.Z",),
    "raw": ("raw.R", "raw.G", "raw.B"),
}


def _plane(data: bytearray, width: int, height: int) -> np.ndarray:
    # A bytearray is writable, so NumPy wraps it without a copy and the array is writable too.
    return np.frombuffer(data, dtype=np.float32).reshape(height, width)


def _rgb_bytes(image: Any) -> tuple[bytes, int, int]:
    """An H x W x 3 array as contiguous float32 bytes, with its width and height."""
    a = np.ascontiguousarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"an image is an H x W x 3 array, not one of shape {a.shape}")
    return a.tobytes(), a.shape[1], a.shape[0]


class Result:
    """A render: the image, its AOV layers, the error estimate and the command line's `--json` summary.

    image     H x W x 3 float32 array of linear radiance (denoised when `denoise=True`)
    aovs      the layers asked for, by name: albedo, normal (H x W x 3), variance (H x W x 3, the
              estimate's variance), depth, spp (H x W); "raw", the image before denoising, when denoised
    error     the estimated relative error of the image (None below 2 samples per pixel)
    summary   the object `vkpath render --json` prints (spp, seconds, samples_per_second, stop_reason,
              device, kernel, ...)
    """

    def __init__(self, summary: dict, image: np.ndarray, aovs: dict, scene: "Scene"):
        self.summary = summary
        self.image = image
        self.aovs = aovs
        self._scene = scene

    @property
    def error(self) -> Optional[float]:
        return self.summary["estimated_rel_error"]

    @property
    def spp(self) -> int:
        return self.summary["spp"]

    @property
    def interrupted(self) -> bool:
        return self.summary["stop_reason"] == "interrupted"

    def write(self, path: PathLike, aovs: bool = True) -> None:
        """The image to a PNG (through the scene's display transform) or an EXR (with the layers, unless
        `aovs` is false)."""
        exr = os.fspath(path).lower().endswith(".exr")
        write(path, self.image, aovs=self.aovs if aovs and exr else None, scene=self._scene)

    def _repr_png_(self) -> bytes:
        # Jupyter shows a Result as its image, through the scene's display transform.
        data, width, height = _rgb_bytes(self.image)
        return _vkpath.png(data, width, height, self._scene._native)

    def __repr__(self) -> str:
        h, w, _ = self.image.shape
        error = "unknown" if self.error is None else f"{100 * self.error:.2f}%"
        return f"<vkpath.Result {w}x{h}, {self.spp} spp, error {error}, {self.summary['stop_reason']}>"


class Scene:
    """A scene vkpath has read; edit it between renders with the `set_*` methods.

    An edit changes the scene's vkpath TOML document (`Scene.toml`: a TOML file's own text, or what a
    glTF or Mitsuba XML file becomes, as `vkpath convert` writes it) and reads it again with the same
    checks as a scene file; the mesh files and images it names are not read again. A bad edit raises
    ValueError and leaves the scene as it was.
    """

    def __init__(self, native: Any):
        self._native = native

    # -- what the scene is ---------------------------------------------------------------------------
    @property
    def toml(self) -> str:
        """The vkpath TOML document the scene is read from, with the edits."""
        return self._native.toml

    def as_dict(self) -> dict:
        """The document as nested dicts (what `load_dict` takes)."""
        return json.loads(self._native.json())

    @property
    def warnings(self) -> list:
        """What the reader noticed and worked around when the file was loaded, one sentence each."""
        return list(self._native.warnings)

    @property
    def width(self) -> int:
        return self._native.width

    @property
    def height(self) -> int:
        return self._native.height

    @property
    def camera(self) -> dict:
        return self.as_dict().get("camera", {})

    @property
    def materials(self) -> list:
        """The materials' names, in the scene's order."""
        return list(self._native.material_names)

    def material(self, name: str) -> dict:
        """A material's keys as the scene format writes them."""
        materials = self.as_dict().get("materials", {})
        if name not in materials:
            raise KeyError(f"the scene has no material {name!r}; its materials are {self.materials}")
        return materials[name]

    @property
    def lights(self) -> list:
        """The `[[light]]` tables (emitting surfaces are materials with `emission`)."""
        return self.as_dict().get("light", [])

    # -- edits ---------------------------------------------------------------------------------------
    def _replace(self, doc: dict) -> None:
        self._native.replace(json.dumps(doc, allow_nan=False))

    def set(self, table: str, **keys: Any) -> None:
        """Sets keys of a top-level table (`camera`, `image`, `render`, `environment`)."""
        doc = self.as_dict()
        doc.setdefault(table, {}).update(keys)
        self._replace(doc)

    def set_camera(self, **keys: Any) -> None:
        """E.g. `set_camera(position=[0, 1, 5], look_at=[0, 1, 0], fov=40)`: the `[camera]` keys."""
        self.set("camera", **keys)

    def set_size(self, width: int, height: int) -> None:
        """The film's size in pixels (`image.width`, `image.height`)."""
        self.set("image", width=width, height=height)

    def set_material(self, name: str, **keys: Any) -> None:
        """Sets keys of the material `name` (e.g. `albedo=[0.8, 0.1, 0.1]`, `roughness=0.2`); `type=...`
        with its keys makes it another kind of material."""
        doc = self.as_dict()
        materials = doc.get("materials", {})
        if name not in materials:
            raise KeyError(f"the scene has no material {name!r}; its materials are {self.materials}")
        if "type" in keys and keys["type"] != materials[name].get("type"):
            materials[name] = {}
        materials[name].update(keys)
        self._replace(doc)

    def set_light(self, index: int, **keys: Any) -> None:
        """Sets keys of the `[[light]]` number `index` (from 0), e.g. `power=500` (W)."""
        doc = self.as_dict()
        lights = doc.get("light", [])
        if not 0 <= index < len(lights):
            raise IndexError(f"the scene has {len(lights)} [[light]] tables; light {index} is not one")
        lights[index].update(keys)
        self._replace(doc)

    def set_environment(self, map: Optional[PathLike] = None, **keys: Any) -> None:
        """Replaces the scene's light from infinitely far, as `vkpath render --environment MAP` does:
        `[environment]` becomes `map` (an equirectangular .exr or .hdr of linear radiance) with `keys`
        (`radiance`, ...), and `render.background` goes."""
        doc = self.as_dict()
        table = dict(keys)
        if map is not None:
            table["map"] = os.path.abspath(os.fspath(map))
        doc["environment"] = table
        doc.get("render", {}).pop("background", None)
        self._replace(doc)

    # -- rendering -----------------------------------------------------------------------------------
    def render(
        self,
        spp: Optional[int] = None,
        time: Optional[float] = None,
        target_error: Optional[float] = None,
        seed: Optional[int] = None,
        aovs: Iterable[str] = (),
        denoise: bool = False,
        progress: Optional[Callable[[int, int], Any]] = None,
    ) -> Result:
        """Renders the scene as `vkpath render` does with the same flags.

        spp            samples per pixel (default the scene's); with `time` or `target_error`, the most
        time           stop after the first pass that ends past this many seconds
        target_error   stop once the estimated relative error is below this (checked from 16 spp on)
        seed           the random seed (default the scene's)
        aovs           layers to render beside the image: albedo, normal, variance, depth, spp
        denoise        denoise the image with Intel Open Image Denoise (the raw image is aovs["raw"])
        progress       called after each pass as progress(samples_done, samples_target); an exception
                       it raises stops the render and is raised here
        Ctrl-C (KeyboardInterrupt) stops the render after the pass in flight: the result holds what was
        sampled (result.interrupted is True).
        """
        summary, width, height, channels, _ = self._native.render(
            spp=spp,
            time=time,
            target_error=target_error,
            seed=seed,
            aovs=list(aovs),
            denoise=denoise,
            progress=progress,
        )
        planes = {name: _plane(data, width, height) for name, data in channels}
        image = np.stack([planes["R"], planes["G"], planes["B"]], axis=-1)
        layers = {}
        for layer, names in _LAYERS.items():
            if names[0] in planes:
                stacked = [planes[n] for n in names]
                layers[layer] = stacked[0] if len(stacked) == 1 else np.stack(stacked, axis=-1)
        return Result(json.loads(summary), image, layers, self)

    def __repr__(self) -> str:
        return f"<vkpath.Scene {self.width}x{self.height}, {len(self.materials)} materials>"


def load(path: PathLike, camera: Union[int, str, None] = None, xml_lenient: bool = False, **defines: Any) -> Scene:
    """Reads a scene file: vkpath TOML, glTF 2.0 (.gltf, .glb) or Mitsuba 3 XML (.xml).

    camera        a glTF scene's camera (an index, or "auto": framed from its bounds), a Mitsuba
                  scene's sensor index
    xml_lenient   a Mitsuba XML scene: skip what vkpath does not read, with a warning each
    **defines     a Mitsuba XML scene's `<default>` parameters, as `-D name=value` (e.g. spp=64,
                  integrator="path")
    """
    cam = None if camera is None else str(camera)
    pairs = [(k, _define_text(v)) for k, v in defines.items()]
    return Scene(_vkpath.load(os.fspath(path), pairs, camera=cam, xml_lenient=xml_lenient))


def _define_text(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def load_dict(scene: Mapping[str, Any], base_dir: Optional[PathLike] = None) -> Scene:
    """A scene given as nested dicts with the TOML format's tables and keys (what `tomllib.load` makes
    of a scene file); relative file paths start from `base_dir` (default: the working directory)."""
    text = json.dumps(scene, allow_nan=False, default=_jsonable)
    return Scene(_vkpath.load_dict(text, os.fspath(base_dir if base_dir is not None else os.getcwd())))


def _jsonable(v: Any) -> Any:
    # NumPy arrays and scalars in a scene dict, as the lists and numbers the format takes.
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    raise TypeError(f"a scene value cannot be {type(v).__name__}: use str, int, float, bool, list, dict")


def write(path: PathLike, image: Any, aovs: Optional[Mapping[str, Any]] = None, scene: Optional[Scene] = None) -> None:
    """Writes an H x W x 3 image: a .png through the display transform (the scene's exposure, gamma and
    tonemap, or a scene file's defaults), an .exr linear, with `aovs` (a Result's) as extra layers named
    as `vkpath render --aov` names them. Written atomically."""
    data, width, height = _rgb_bytes(image)
    layers = []
    for name, array in (aovs or {}).items():
        if name not in _LAYERS:
            raise ValueError(f"{name!r} is not a layer vkpath writes; the layers are {list(_LAYERS)}")
        a = np.ascontiguousarray(array, dtype=np.float32).reshape(height, width, -1)
        channels = _LAYERS[name]
        if a.shape[2] != len(channels):
            raise ValueError(f"the {name} layer has {len(channels)} channels, not {a.shape[2]}")
        for c, channel in enumerate(channels):
            layers.append((channel, np.ascontiguousarray(a[:, :, c]).tobytes()))
    native = scene._native if scene is not None else None
    _vkpath.write(os.fspath(path), data, width, height, layers, scene=native)


def kernels_compiled() -> int:
    """How many kernels this process has compiled: one per set of features rendered (an edit that
    changes only values, a colour or a power or the camera, compiles none)."""
    return _vkpath.kernels_compiled()


def read(path: PathLike) -> np.ndarray:
    """An image file's RGB values as `vkpath compare` reads them: an EXR's linear values, a PNG's 8-bit
    values (0..255), as an H x W x 3 float32 array."""
    data, width, height = _vkpath.read_image(os.fspath(path))
    return np.frombuffer(data, dtype=np.float32).reshape(height, width, 3)


def compare(a: Any, b: Any) -> dict:
    """`vkpath compare A B`: whether two images (arrays, or .png/.exr paths) hold the same values, and
    how far apart they are: identical, differing_values, max_abs_difference, rel_rmse (relative to b)."""
    a = read(a) if isinstance(a, (str, os.PathLike)) else np.asarray(a, dtype=np.float32)
    b = read(b) if isinstance(b, (str, os.PathLike)) else np.asarray(b, dtype=np.float32)
    if a.shape != b.shape:
        raise ValueError(f"the images are {a.shape} and {b.shape}: only images of the same size can be compared")
    height, width = a.shape[0], a.shape[1]
    return json.loads(
        _vkpath.compare(np.ascontiguousarray(a).tobytes(), np.ascontiguousarray(b).tobytes(), width, height)
    )
