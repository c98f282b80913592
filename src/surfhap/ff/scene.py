"""Force-feedback scenes as data: effects and haptic maps over a picture, with provenance.

A scene file is JSON (``"format": "surfhap-ff-scene", "schema_version": 1``)::

    {"name": "...", "size_m": [0.197, 0.148], "provenance": {"k_mat": "004 Sec. 3.2", ...},
     "picture": {"image": "garden.png"},
     "effects": [
        {"type": "stiffness", "k_mat": {"image": "stiffness.png", "range": [100, 1000]}},
        {"type": "shape", "height": {"rects": [...], "default": 0.0}},
        {"type": "shape", "mesh": {"path": "suzanne", "size_m": 0.08, "height_m": 0.03}},
        {"type": "roughness", "depth": 2e-4, "period_m": 1.5e-3},
        {"type": "sliding", "alpha": 1.0, "nu": 20},
        {"type": "attraction", "points": [{"x": 0.1, "y": 0.05, "radius": 0.02, "strength": 1.0}]}],
     "buttons": [{"name": "OK", "x0": 0.01, "y0": 0.05, "x1": 0.05, "y1": 0.09,
                  "click_depth_m": 0.0015, "release_depth_m": 0.0008}]}

``buttons`` (optional) are GUI buttons that emit press events when the screen is pushed
past their click depth (:mod:`surfhap.ff.buttons`); their feel comes from the effects.

A *map* (a number or an object) is a scalar field over the content rectangle
``[0, width] x [0, height]`` (touch coordinates, m; y grows downwards like the image rows):

* ``{"constant": v}``;
* ``{"image": "file.png" | "file.npy", "range": [lo, hi], "threshold": t}`` - grey levels
  0..1 mapped linearly onto lo..hi; pixels darker than ``threshold`` are "no effect here";
* ``{"rects": [{"x0", "y0", "x1", "y1", "value"} | {..., "ramp": {"axis": "x", "from": a,
  "to": b}}], "default": v | null}`` - rectangles in m, the last one containing the point
  wins; ``null`` default = no effect outside them.

Paths are relative to the scene file. Errors name the file and the field, and are
:class:`surfhap.errors.SceneFormatError` (the CLI prints one line and exits 2).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field as PField, ValidationError, model_validator

from surfhap.checked import within
from surfhap.errors import SceneFormatError
from surfhap.ff.buttons import Button
from surfhap.ff.effects import Attraction, Effect, Roughness, Shape, Sliding, Stiffness
from surfhap.ff.fields import ConstantField, Field, GridField, MeshHeightField, Ramp as RampValue, RectsField
from surfhap.ff.params import DeviceParams

__all__ = ["SceneSpec", "FFScene", "load_scene", "load_ff_scene", "builtin_scene_names", "builtin_scene_path"]

class _Strict(BaseModel):  # every part of a scene file: unknown keys are errors
    model_config = ConfigDict(extra="forbid")


class Ramp(_Strict):
    axis: Literal["x", "y"]
    from_: float = PField(alias="from")
    to: float


class Rect(_Strict):
    x0: float
    y0: float
    x1: float
    y1: float
    value: float | None = None
    ramp: Ramp | None = None

    @model_validator(mode="after")
    def _check(self):
        if not (self.x1 > self.x0 and self.y1 > self.y0):
            raise ValueError("a rectangle needs x1 > x0 and y1 > y0")
        if (self.value is None) == (self.ramp is None):
            raise ValueError("a rectangle needs exactly one of value or ramp")
        return self


class MapSpec(_Strict):
    constant: float | None = None
    image: str | None = None
    range: tuple[float, float] = (0.0, 1.0)
    threshold: float | None = PField(None, ge=0.0, le=1.0)
    rects: list[Rect] | None = None
    default: float | None = None

    @model_validator(mode="after")
    def _one(self):
        if sum(v is not None for v in (self.constant, self.image, self.rects)) != 1:
            raise ValueError("a map needs exactly one of constant, image or rects")
        return self


MapLike = Union[float, MapSpec]


class MeshSpec(_Strict):
    path: str
    up: Literal["x", "y", "z", "-x", "-y", "-z"] = "z"
    size_m: float = PField(0.08, gt=0.0, le=1.0)
    height_m: float = PField(0.02, gt=0.0, le=0.2)
    center_m: tuple[float, float] | None = None


class StiffnessSpec(_Strict):
    type: Literal["stiffness"]
    k_mat: MapLike  # N/m


class ShapeSpec(_Strict):
    type: Literal["shape"]
    height: MapLike | None = None  # m
    mesh: MeshSpec | None = None
    scale: float = 1.0

    @model_validator(mode="after")
    def _one(self):
        if (self.height is None) == (self.mesh is None):
            raise ValueError("a shape needs exactly one of height or mesh")
        return self


class RoughnessSpec(_Strict):
    type: Literal["roughness"]
    depth: MapLike  # m
    period_m: float = PField(gt=0.0, le=0.1)


class SlidingSpec(_Strict):
    type: Literal["sliding"]
    alpha: MapLike
    nu: float = PField(20.0, ge=0.0, le=100.0)
    inertia: bool = True


class PointSpec(_Strict):
    x: float
    y: float
    radius: float = PField(gt=0.0)
    strength: float = PField(ge=-8.0, le=8.0)


class AttractionSpec(_Strict):
    type: Literal["attraction"]
    points: list[PointSpec] = PField(min_length=1)


EffectSpec = Annotated[Union[StiffnessSpec, ShapeSpec, RoughnessSpec, SlidingSpec, AttractionSpec],
                       PField(discriminator="type")]


_Size = within(0.01, 2.0, "size_m must be within 0.01-2 m")


class SceneSpec(_Strict):
    """The JSON schema of a scene file (see the module docstring)."""

    format: Literal["surfhap-ff-scene"]
    schema_version: Literal[1]
    name: str
    description: str = ""
    size_m: tuple[_Size, _Size]
    picture: MapSpec | None = None
    effects: list[EffectSpec] = PField(min_length=1, max_length=30)
    buttons: list[Button] = PField(default_factory=list, max_length=64)
    provenance: dict[str, str] = PField(default_factory=dict)


@dataclass
class FFScene:
    """A loaded scene: ``spec``, the ``effects`` (for one device) and the ``picture`` field."""

    spec: SceneSpec
    effects: list[Effect]
    picture: Field | None
    source: str

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def size(self) -> tuple[float, float]:
        return tuple(self.spec.size_m)

    @property
    def buttons(self) -> list[Button]:
        """The scene's GUI buttons (press events), [] for none."""
        return list(self.spec.buttons)

    def picture_array(self, n: int = 200) -> np.ndarray:
        """(ny, nx) picture sampled for display (zeros if the scene has none)."""
        w, h = self.size
        ny = max(2, int(round(n * h / w)))
        if self.picture is None:
            return np.zeros((ny, n))
        X, Y = np.meshgrid((np.arange(n) + 0.5) * w / n, (np.arange(ny) + 0.5) * h / ny)
        return np.nan_to_num(np.vectorize(self.picture.value, otypes=[float])(X, Y))


def _read_image(path: Path, src: str, field: str) -> np.ndarray:
    if path.suffix.lower() == ".npy":
        try:
            a = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise SceneFormatError(f"cannot read {path.name} ({exc})", source=src, field=field) from None
        if a.ndim != 2 or a.size == 0 or not np.all(np.isfinite(a)):
            raise SceneFormatError(f"{path.name} must be a finite 2-D array", source=src, field=field)
        return a.astype(float)
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            a = np.asarray(im.convert("L"), dtype=float) / 255.0
    except (OSError, UnidentifiedImageError) as exc:
        raise SceneFormatError(f"cannot read image {path.name} ({type(exc).__name__})", source=src, field=field) from None
    return a


def _field(m, size, base: Path, src: str, field: str) -> Field:
    if isinstance(m, (int, float)):
        return ConstantField(float(m))
    if m.constant is not None:
        return ConstantField(m.constant)
    if m.rects is not None:
        rects = [(r.x0, r.y0, r.x1, r.y1, r.value if r.ramp is None else RampValue(r.ramp.axis == "x", r.ramp.from_, r.ramp.to))
                 for r in m.rects]
        return RectsField(rects, np.nan if m.default is None else m.default)
    img = _read_image(base / m.image, src, f"{field}.image")
    lo, hi = m.range
    data = lo + (hi - lo) * img
    if m.threshold is not None:
        data = np.where(img < m.threshold, np.nan, data)
    return GridField(data, 0.0, 0.0, size[0], size[1])


def _mesh_field(ms: MeshSpec, size, base: Path, src: str) -> Field:
    from surfhap.errors import MeshFormatError
    from surfhap.exchange.mesh import builtin_mesh_path, read_mesh
    from surfhap.shape.topsurface import TopSurface

    p = builtin_mesh_path(ms.path) or (base / ms.path)
    try:
        m = read_mesh(p, up=ms.up, size=ms.size_m)
    except (MeshFormatError, OSError) as exc:
        raise SceneFormatError(str(exc), source=src, field="mesh.path") from None
    v = np.array(m.vertices, dtype=float)
    zr = np.ptp(v[:, 2])
    v[:, 2] = (v[:, 2] - v[:, 2].min()) * (ms.height_m / zr if zr > 0 else 1.0)
    cx, cy = ms.center_m if ms.center_m is not None else (size[0] / 2, size[1] / 2)
    v[:, 0] += cx
    v[:, 1] = cy - v[:, 1]  # mesh y up -> touch y down
    surf = TopSurface(v, np.asarray(m.faces)[:, ::-1], name=m.name, source=str(p))
    return MeshHeightField(surf, base=0.0)


def build_effects(spec: SceneSpec, device: DeviceParams, base: Path, src: str) -> list[Effect]:
    """The effects of ``spec`` for ``device`` (K_max, moving mass)."""
    out: list[Effect] = []
    km = device.k_max
    for i, e in enumerate(spec.effects):
        def m(name: str, e=e, i=i) -> Field:  # the effect's map ``name``
            return _field(getattr(e, name), spec.size_m, base, src, f"effects.{i}.{name}")

        if e.type == "stiffness":
            out.append(Stiffness(m("k_mat"), k_max=km))
        elif e.type == "shape":
            h = _mesh_field(e.mesh, spec.size_m, base, src) if e.mesh is not None else m("height")
            out.append(Shape(h, scale=e.scale, k_max=km))
        elif e.type == "roughness":
            out.append(Roughness(m("depth"), e.period_m, k_max=km))
        elif e.type == "sliding":
            out.append(Sliding(m("alpha"), nu=e.nu, mass=device.moving_mass if e.inertia else 0.0, k_max=km))
        else:
            out.append(Attraction([(p.x, p.y, p.radius, p.strength) for p in e.points], k_max=km))
    return out


def builtin_scene_names() -> list[str]:
    return sorted(p.name[:-5] for p in files("surfhap.ff").joinpath("scenes").iterdir() if p.name.endswith(".json"))


def builtin_scene_path(name: str) -> Path:
    return Path(str(files("surfhap.ff").joinpath("scenes", f"{name}.json")))


def load_scene(ref: str | Path, device: DeviceParams | None = None) -> FFScene:
    """A built-in scene by name or a scene file by path; raises SceneFormatError."""
    device = device or DeviceParams()
    path = Path(ref)
    if not path.exists() and str(ref) in builtin_scene_names():
        path = builtin_scene_path(str(ref))
    src = str(path)
    try:
        raw = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SceneFormatError(f"cannot read file ({exc.strerror}); built-in scenes: {', '.join(builtin_scene_names())}",
                               source=src) from None
    except UnicodeDecodeError:
        raise SceneFormatError("not a UTF-8 text file", source=src) from None
    except json.JSONDecodeError as exc:
        raise SceneFormatError(f"malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", source=src) from None
    if not isinstance(raw, dict):
        raise SceneFormatError("top level must be a JSON object", source=src)
    try:
        spec = SceneSpec.model_validate(raw)
    except ValidationError as exc:
        errs = exc.errors()
        # a map is "number or object": report the object branch's error when one was given
        def _tag(p) -> bool:  # pydantic's union-branch markers in a location
            return isinstance(p, str) and (p in ("float", "MapSpec") or p.startswith("function-"))

        first = next((e for e in errs if any(_tag(p) and p != "float" for p in e.get("loc", ()))), errs[0])
        loc = [str(p) for p in first.get("loc", ()) if not _tag(p)]
        # drop the discriminator tag pydantic inserts ("effects.0.stiffness.k_mat")
        if len(loc) > 2 and loc[0] == "effects" and loc[2] in ("stiffness", "shape", "roughness", "sliding", "attraction"):
            loc.pop(2)
        raise SceneFormatError(first.get("msg", "invalid value"), source=src, field=".".join(loc) or None) from None
    try:
        effects = build_effects(spec, device, path.parent, src)
        picture = None if spec.picture is None else _field(spec.picture, spec.size_m, path.parent, src, "picture")
    except ValueError as exc:
        if isinstance(exc, SceneFormatError):
            raise
        raise SceneFormatError(str(exc), source=src) from None
    return FFScene(spec, effects, picture, src)


load_ff_scene = load_scene  # the name re-exported by ``surfhap`` (``load_scene`` is ambiguous there)
