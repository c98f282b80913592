"""Mesh files: OBJ, STL, PLY, glTF/GLB, OFF (anything trimesh reads) with clear errors.

A mesh that cannot be used (unreadable, unknown format, no triangles, NaN coordinates)
raises :class:`surfhap.errors.MeshFormatError` naming the file, which the CLI prints as one
line with exit code 2.

Units: surfhap works in SI, so mesh coordinates are taken as metres unless ``scale`` (a
factor, e.g. 0.01 for a mesh in cm) or ``size`` (the width in metres the mesh should span on
the screen) says otherwise. ``up`` names the mesh axis that points out of the screen
(``z`` by default; ``y`` for the many meshes, like the Stanford bunny, that are modelled
+Y up).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from surfhap.errors import MeshFormatError, MeshUnitsWarning

__all__ = ["MeshData", "read_mesh", "arrays_from_trimesh", "check_mesh", "orient_up", "builtin_mesh_path", "BUILTIN_MESHES",
           "PLAUSIBLE_EXTENT_M", "place_mesh"]

#: (smallest, largest) plausible top-view extent of a mesh in metres: a touch surface is
#: millimetres to decimetres across; outside this a mesh was most likely modelled in other units
PLAUSIBLE_EXTENT_M = (1e-3, 1.0)

# Meshes shipped in surfhap/data (name -> file name).
BUILTIN_MESHES = {"suzanne": "suzanne.obj"}

_UP = ("x", "y", "z", "-x", "-y", "-z")


@dataclass(frozen=True)
class MeshData:
    """A loaded triangle mesh: vertices (nv, 3) float, faces (nf, 3) int64."""

    vertices: np.ndarray
    faces: np.ndarray
    name: str
    source: str


def builtin_mesh_path(name: str) -> Path | None:
    """Path of a mesh shipped with surfhap (``suzanne``), or None."""
    fname = BUILTIN_MESHES.get(name.lower())
    if fname is None:
        return None
    from importlib.resources import files

    return Path(str(files("surfhap") / "data" / fname))


def orient_up(vertices: np.ndarray, up: str) -> np.ndarray:
    """Rotate (n, 3) vertices so that the axis ``up`` (x, y, z, -x, -y, -z) becomes +z.

    Proper rotations only (no mirroring), so face winding and outward normals survive.
    """
    v = np.asarray(vertices, dtype=float)
    if up not in _UP:
        raise MeshFormatError(f"up must be one of {', '.join(_UP)}, got {up!r}", field="up")
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    rot = {
        "z": (x, y, z),
        "-z": (x, -y, -z),
        "y": (x, -z, y),  # rotate -90 deg about x: +y -> +z
        "-y": (x, z, -y),
        "x": (-z, y, x),  # rotate -90 deg about y: +x -> +z
        "-x": (z, y, -x),
    }[up]
    return np.column_stack(rot)


def arrays_from_trimesh(mesh, source: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """(vertices (nv, 3) float, faces (nf, 3) int64) from a trimesh Trimesh or Scene."""
    import trimesh

    if isinstance(mesh, trimesh.Scene):
        geoms = [g for g in mesh.dump() if isinstance(g, trimesh.Trimesh)] if mesh.geometry else []
        if not geoms:
            raise MeshFormatError("the file holds no triangle mesh (empty scene, or only points/lines)", source=source)
        mesh = trimesh.util.concatenate(geoms)
    if not isinstance(mesh, trimesh.Trimesh):
        raise MeshFormatError(f"not a triangle mesh ({type(mesh).__name__})", source=source)
    return check_mesh(mesh.vertices, mesh.faces, source)


def check_mesh(vertices, faces, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (nv, 3) float64, faces (nf, 3) int64), contiguous; MeshFormatError naming
    ``source`` unless they are a non-empty, finite triangle mesh whose faces index its vertices."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise MeshFormatError(f"vertices must be an (n, 3) array, got shape {v.shape}", source=source)
    if f.ndim != 2 or f.shape[1] != 3:
        raise MeshFormatError(f"faces must be an (m, 3) array of triangles, got shape {f.shape}", source=source)
    if f.shape[0] == 0 or v.shape[0] < 3:
        raise MeshFormatError("the mesh is empty (no triangles)", source=source)
    if not np.all(np.isfinite(v)):
        raise MeshFormatError("vertex coordinates contain NaN or inf", source=source)
    if f.min() < 0 or f.max() >= v.shape[0]:
        raise MeshFormatError(f"face indices outside 0..{v.shape[0] - 1}", source=source)
    return v, f


def place_mesh(vertices: np.ndarray, up: str, scale: float, size: float | None, source: str) -> np.ndarray:
    """(n, 3) vertices turned so ``up`` is +z (:func:`orient_up`), times ``scale``, and with
    ``size``: centred on x = y = 0 with the larger xy side ``size`` m (see :func:`read_mesh`).
    Warns (:class:`MeshUnitsWarning`) when the larger side of the result's top-view (x-y)
    extent (metres) is outside :data:`PLAUSIBLE_EXTENT_M`."""
    v = orient_up(vertices, up) * float(scale)
    if size is not None:
        lo, hi = v.min(axis=0), v.max(axis=0)
        extent = float(max(hi[0] - lo[0], hi[1] - lo[1]))
        if extent <= 0:
            raise MeshFormatError("the mesh has no extent in x and y", source=source)
        centre = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.0])
        v = (v - centre) * (size / extent)
    extent = float(np.max(np.ptp(v[:, :2], axis=0))) if v.size else 0.0
    lo, hi = PLAUSIBLE_EXTENT_M
    if not lo <= extent <= hi:
        guess = "millimetres" if extent > hi else "kilometres"
        warnings.warn(MeshUnitsWarning(f"the mesh spans {extent:.4g} m across, read as metres; if it is in {guess}, "
                                       f"rescale it with --size METRES (the width it should span, e.g. --size 0.05) "
                                       "or --scale", source=source), stacklevel=3)
    return v


def read_mesh(path: str | Path, *, up: str = "z", scale: float = 1.0, size: float | None = None) -> MeshData:
    """Load a mesh file (or a built-in name such as ``suzanne``) as triangles.

    up    : mesh axis that points out of the screen (becomes +z).
    scale : factor from mesh units to metres (1.0: the mesh is in metres).
    size  : if given, rescale (after ``scale``) so the larger side of the mesh's xy extent
            is ``size`` metres; the mesh is also centred on x = y = 0.
    Raises MeshFormatError for anything unusable; warns (:class:`MeshUnitsWarning`) when the
    result is not 1 mm to 1 m across (a mesh in millimetres read as metres, say).
    """
    import trimesh

    p = Path(path)
    src = str(path)
    if not p.exists():
        builtin = builtin_mesh_path(str(path))
        if builtin is None:
            raise MeshFormatError("no such file (and not a built-in mesh: " + ", ".join(BUILTIN_MESHES) + ")", source=src)
        p = builtin
    if p.is_dir():
        raise MeshFormatError("is a folder, not a mesh file", source=src)
    if not (np.isfinite(scale) and scale > 0):
        raise MeshFormatError(f"scale must be > 0, got {scale}", source=src, field="scale")
    if size is not None and not (np.isfinite(size) and size > 0):
        raise MeshFormatError(f"size must be > 0 m, got {size}", source=src, field="size")
    if p.stat().st_size == 0:
        raise MeshFormatError("empty file", source=src)
    ext = p.suffix.lower().lstrip(".")
    if ext not in trimesh.available_formats():
        raise MeshFormatError(f"unknown mesh format {p.suffix!r} (try OBJ, STL, PLY, GLB/glTF, OFF)", source=src)
    try:
        loaded = trimesh.load(str(p), force="mesh", process=True)
    except MeshFormatError:
        raise
    except ImportError as exc:  # one of trimesh's optional readers is not installed
        raise MeshFormatError(f"cannot parse the {ext.upper()} file: trimesh needs the package {exc.name!r} "
                              "for it (pip install it)", source=src) from None
    except Exception as exc:  # trimesh raises many kinds for malformed files
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise MeshFormatError(f"cannot parse the {ext.upper()} file ({msg[:160]})", source=src) from None
    v, f = arrays_from_trimesh(loaded, source=src)
    return MeshData(place_mesh(v, up, scale, size, src), f, p.stem, src)
