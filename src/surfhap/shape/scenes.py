"""Built-in shapes and the 20 scenes of Kim et al.'s summative study (Sec. 5.1.1, Fig. 11-12).

Shapes (paper Fig. 11; the paper gives them in cm, surfhap builds them in metres):

* Gaussian bump: ``z(x, y) = 8 / (1.4 pi) exp(-(x^2 + y^2) / 1.4)`` (x, y, z in cm) over a
  6 x 6 cm patch, height 1.82 cm; triangulated on a regular grid (``resolution`` m).
* square frustum bump: base square 3 x 3 cm, top square 1 x 1 cm, height 2 cm, standing on a
  6 x 6 cm ground patch; built from its exact planar faces (18 triangles), so its edges are
  mesh edges.
* holes: the bumps inverted (z -> -z), as in the paper.

Scenes: four objects of one profile on a 2 x 2 layout of 6 x 6 cm cells (a 12 x 12 cm
scene), in five configurations 0B4H ... 4B0H, under two lights (a vertical spotlight and a
directional light rotated (45, 45, 0) deg about x, y, z): 2 x 2 x 5 = 20 scenes. The light
only changes the picture, not what is felt. Positions are named TL, TR, BL, BR. The paper
fixes the bump of 1B3H at TR for Gaussian scenes and at BR for frustum scenes and picked the
other layouts at random without listing them; surfhap's (documented) choice: 3B1H is the
complement of 1B3H (the hole where 1B3H has its bump), 2B2H has its bumps on the diagonal
through that position.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from surfhap.errors import ConfigError

__all__ = [
    "CM",
    "gaussian_height",
    "gaussian_bump",
    "frustum_bump",
    "Scene",
    "scene_names",
    "get_scene",
    "all_scenes",
    "builtin_shape_names",
    "builtin_shape",
    "CONFIGURATIONS",
    "LIGHTS",
    "PROFILES",
]

CM = 0.01  # m per cm
GAUSS_A = 8.0 / (1.4 * np.pi)  # cm, peak height (Fig. 11a)
GAUSS_S = 1.4  # cm^2, exp(-(x^2 + y^2) / 1.4) (Fig. 11a)
PATCH = 6.0  # cm, width and length of one object's patch (Fig. 11)
FRUSTUM_BASE = 3.0  # cm (Fig. 11b)
FRUSTUM_TOP = 1.0  # cm (Fig. 11b)
FRUSTUM_HEIGHT = 2.0  # cm (Fig. 11b)

CONFIGURATIONS = ("0B4H", "1B3H", "2B2H", "3B1H", "4B0H")
LIGHTS = ("spot", "directional")
PROFILES = ("gaussian", "frustum")
POSITIONS = ("TL", "TR", "BL", "BR")
_CENTRES = {"TL": (-3.0, 3.0), "TR": (3.0, 3.0), "BL": (-3.0, -3.0), "BR": (3.0, -3.0)}  # cm
_BUMPS = {  # which positions hold bumps, per profile and configuration
    "gaussian": {"0B4H": (), "1B3H": ("TR",), "2B2H": ("TR", "BL"), "3B1H": ("TL", "BL", "BR"),
                 "4B0H": POSITIONS},
    "frustum": {"0B4H": (), "1B3H": ("BR",), "2B2H": ("BR", "TL"), "3B1H": ("TL", "TR", "BL"),
                "4B0H": POSITIONS},
}


def gaussian_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Height (m) of the Gaussian bump centred at 0, x and y in m (Fig. 11a)."""
    xc = np.asarray(x, dtype=float) / CM
    yc = np.asarray(y, dtype=float) / CM
    return GAUSS_A * np.exp(-(xc * xc + yc * yc) / GAUSS_S) * CM


def _grid_mesh(xs: np.ndarray, ys: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a height grid z (ny, nx) over xs (nx,), ys (ny,): (vertices, faces), CCW
    seen from above."""
    nx, ny = xs.size, ys.size
    X, Y = np.meshgrid(xs, ys)
    v = np.column_stack([X.ravel(), Y.ravel(), np.asarray(z, dtype=float).ravel()])
    idx = np.arange(nx * ny).reshape(ny, nx)
    a = idx[:-1, :-1].ravel()
    b = idx[:-1, 1:].ravel()
    c = idx[1:, 1:].ravel()
    d = idx[1:, :-1].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return v, f.astype(np.int64)


def _gaussian_mesh(resolution: float, centre: tuple[float, float], half: float, bumps) -> tuple[np.ndarray, np.ndarray]:
    """Grid step ``resolution`` m over the square of half-width ``half`` cm around ``centre`` (cm)
    of the sum of ``sign`` x Gaussian bump at each ``(cx, cy, sign)`` of ``bumps`` (cm)."""
    if not (np.isfinite(resolution) and 1e-5 <= resolution <= 0.01):
        raise ConfigError(f"must be within 1e-5..0.01 m, got {resolution}", field="resolution")
    n = int(round(2 * half * CM / resolution)) + 1
    xs = (np.linspace(-half, half, n) + centre[0]) * CM
    ys = (np.linspace(-half, half, n) + centre[1]) * CM
    X, Y = np.meshgrid(xs, ys)
    return _grid_mesh(xs, ys, sum(sign * gaussian_height(X - cx * CM, Y - cy * CM) for cx, cy, sign in bumps))


def gaussian_bump(resolution: float = 0.0005, hole: bool = False, centre: tuple[float, float] = (0.0, 0.0),
                  patch: float = PATCH) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian bump (or hole) on a ``patch`` cm square, grid step ``resolution`` m.

    Returns (vertices (nv, 3) float m, faces (nf, 3) int).
    """
    return _gaussian_mesh(resolution, centre, patch / 2, [(*centre, -1.0 if hole else 1.0)])


def frustum_bump(hole: bool = False, centre: tuple[float, float] = (0.0, 0.0), patch: float = PATCH,
                 base: float = FRUSTUM_BASE, top: float = FRUSTUM_TOP, height: float = FRUSTUM_HEIGHT
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Square frustum bump (or hole) on a ``patch`` cm ground square (Fig. 11b), from its
    planar faces. Returns (vertices (24, 3) float m... (nv, 3), faces (18, 3) int)."""
    rings = ((patch / 2, 0.0), (base / 2, 0.0), (top / 2, -height if hole else height))  # ground, base, top
    v = np.array([(sx * half + centre[0], sy * half + centre[1], z) for half, z in rings
                  for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))], dtype=float)
    faces = []
    for r in range(2):  # ground ring (outer -> base), then sides (base -> top)
        o, i = 4 * r, 4 * (r + 1)
        for k in range(4):
            k1 = (k + 1) % 4
            faces.append((o + k, o + k1, i + k1))
            faces.append((o + k, i + k1, i + k))
    faces.append((8, 9, 10))
    faces.append((8, 10, 11))
    return v * CM, np.array(faces, dtype=np.int64)


@dataclass(frozen=True)
class Scene:
    """One scene of the summative study: ``profile`` (gaussian | frustum), ``configuration``
    (0B4H..4B0H), ``light`` (spot | directional), and ``bumps``: positions holding bumps."""

    profile: str
    configuration: str
    light: str
    bumps: tuple[str, ...]

    @property
    def name(self) -> str:
        return f"{self.profile}-{self.configuration}-{self.light}"

    @property
    def layout(self) -> dict[str, str]:
        """Position -> 'bump' or 'hole'."""
        return {p: ("bump" if p in self.bumps else "hole") for p in POSITIONS}

    @property
    def light_direction(self) -> np.ndarray:
        """(3,) unit vector pointing from the scene towards the light."""
        return light_direction(self.light)

    def mesh(self, resolution: float = 0.001) -> tuple[np.ndarray, np.ndarray]:
        """(vertices (nv, 3) float m, faces (nf, 3) int) of the 12 x 12 cm scene; Gaussian
        scenes are gridded at ``resolution`` m."""
        if self.profile == "gaussian":
            return _gaussian_mesh(resolution, (0.0, 0.0), PATCH, [(*_CENTRES[p], 1.0 if p in self.bumps else -1.0)
                                                                 for p in POSITIONS])
        verts, faces = [], []
        off = 0
        for p in POSITIONS:
            v, f = frustum_bump(hole=p not in self.bumps, centre=_CENTRES[p])
            verts.append(v)
            faces.append(f + off)
            off += v.shape[0]
        v = np.concatenate(verts)
        f = np.concatenate(faces)
        # weld the shared corners of neighbouring patches
        key = np.round(v / 1e-9).astype(np.int64)
        _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
        return v[first], inv.reshape(-1)[f]

    def surface(self, resolution: float = 0.001):
        """The scene as a :class:`~surfhap.shape.topsurface.TopSurface`."""
        from surfhap.shape.topsurface import TopSurface

        v, f = self.mesh(resolution)
        return TopSurface(v, f, name=self.name, source=self.name)


def light_direction(light: str) -> np.ndarray:
    """(3,) unit vector towards the light: 'spot' straight above; 'directional' the downward
    light rotated 45 deg about x, then 45 deg about y (Sec. 5.1.1)."""
    if light == "spot":
        return np.array([0.0, 0.0, 1.0])
    if light == "directional":
        from scipy.spatial.transform import Rotation

        travel = Rotation.from_euler("xy", [45.0, 45.0], degrees=True).apply([0.0, 0.0, -1.0])  # where the light travels
        return -travel / np.linalg.norm(travel)
    raise ConfigError(f"unknown light {light!r} (spot | directional)", field="light")


def all_scenes() -> list[Scene]:
    """The 20 scenes, ordered profile, light, configuration."""
    return [Scene(p, c, light, tuple(_BUMPS[p][c])) for p in PROFILES for light in LIGHTS for c in CONFIGURATIONS]


def scene_names() -> list[str]:
    return [s.name for s in all_scenes()]


def get_scene(name: str) -> Scene:
    """A scene by name, e.g. ``gaussian-1B3H-spot``."""
    for s in all_scenes():
        if s.name.lower() == name.lower():
            return s
    raise ConfigError(f"unknown scene {name!r} (see 'surfhap scenes')", field="scene")


_SINGLE = ("gaussian-bump", "gaussian-hole", "frustum-bump", "frustum-hole")


def builtin_shape_names() -> list[str]:
    """Names :func:`builtin_shape` knows: single shapes, the 20 scenes and 'suzanne'."""
    return [*_SINGLE, *scene_names(), "suzanne"]


def builtin_shape(name: str, resolution: float | None = None):
    """A built-in shape as a TopSurface, or None if ``name`` is not one. Single Gaussian shapes
    use 0.5 mm grids, scenes 1 mm, unless ``resolution`` (m) is given."""
    from surfhap.shape.topsurface import TopSurface

    key = name.lower()
    if key in _SINGLE:
        profile, kind = key.split("-")
        if profile == "gaussian":
            v, f = gaussian_bump(resolution or 0.0005, hole=kind == "hole")
        else:
            v, f = frustum_bump(hole=kind == "hole")
        return TopSurface(v, f, name=key, source=key)
    if key in (n.lower() for n in scene_names()):
        return get_scene(key).surface(resolution or 0.001)
    if key == "suzanne":
        return TopSurface.from_file("suzanne")
    return None
