"""The top-surface index: vertical rays from touch points onto a triangle mesh.

Kim et al. (2017, Sec. 4.1) map a touch point (x, y) to the ray from (x, y, +inf) straight
down (-z) and keep the hit with the greatest height. :class:`TopSurface` answers exactly
that question, for one point or for a whole trajectory at once.

How it works: the triangles are projected onto the xy plane and binned into a uniform grid
(built once per mesh, O(faces)). A query visits the triangles of its cell only, highest
first (each cell is sorted by the triangles' top z), and stops as soon as no remaining
triangle can rise above the best hit. The point-in-triangle test uses edge functions that are
evaluated with the edge's vertices in a canonical order (lower vertex index first), so the
two triangles sharing an edge compute bit-identical values of opposite sign: a point on a
shared edge is never lost in a crack between them (a watertight test). Heights are the
barycentric interpolation of the triangle's vertex heights, i.e. the exact intersection of
the vertical ray with the triangle's plane.

Triangles whose xy projection has zero area (vertical walls) are never hit by a vertical ray
except along their edges, where their neighbours answer; they are skipped.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

from surfhap.errors import MeshFormatError
from surfhap.exchange.mesh import check_mesh
from surfhap.shape.raycast import hit_one

__all__ = ["TopSurface", "TopHits"]

# Largest number of grid cells (memory bound: 8 bytes per cell for the CSR offsets).
_MAX_CELLS = 4_000_000


class TopHits(NamedTuple):
    """Hits of vertical rays: z (n,) float height (NaN where the ray misses the mesh) and
    face (n,) int64 index of the hit triangle (-1 where it misses)."""

    z: np.ndarray
    face: np.ndarray


@numba.njit(cache=True, nogil=True)
def _bin_cells(order, bx0, bx1, by0, by1, x0, y0, inv_cw, inv_ch, nx, ny, ok, fill, items, count_only):
    # count_only: fill[c] += the faces over cell c; else items[fill[c]++] = face. Faces are
    # visited in descending zmax order, so each cell's list comes out sorted
    for k in range(order.shape[0]):
        f = order[k]
        if not ok[f]:
            continue
        i0 = min(max(int((bx0[f] - x0) * inv_cw), 0), nx - 1)
        i1 = min(max(int((bx1[f] - x0) * inv_cw), 0), nx - 1)
        j0 = min(max(int((by0[f] - y0) * inv_ch), 0), ny - 1)
        j1 = min(max(int((by1[f] - y0) * inv_ch), 0), ny - 1)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                c = j * nx + i
                if not count_only:
                    items[fill[c]] = f
                fill[c] += 1


@numba.njit(cache=True, nogil=True)
def _query_kernel(xy, verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items, z_out, f_out):
    for n in range(xy.shape[0]):
        z, f = hit_one(xy[n, 0], xy[n, 1], verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items)
        z_out[n] = z if f >= 0 else np.nan
        f_out[n] = f


def _build_grid(vertices: np.ndarray, faces: np.ndarray, cells_per_face: float = 1.0):
    """Bin the xy projections of the triangles into a uniform grid.

    vertices (nv, 3) float, faces (nf, 3) int. Returns ``(esign, zmax, grid)``: the
    orientation sign (nf,) float of each triangle's xy projection (0 for vertical ones,
    which are left out), each triangle's highest z (nf,) float, and the grid
    ``(x0, y0, 1 / cell width, 1 / cell height, nx, ny, start (nx*ny + 1,) int64 CSR offsets,
    items (k,) int64 face indices, each cell sorted by descending zmax)``.
    """
    v = vertices
    tri = v[faces]  # (nf, 3, 3)
    txy = tri[:, :, :2]
    area2 = ((txy[:, 1, 0] - txy[:, 0, 0]) * (txy[:, 2, 1] - txy[:, 0, 1])
             - (txy[:, 1, 1] - txy[:, 0, 1]) * (txy[:, 2, 0] - txy[:, 0, 0]))
    esign = np.sign(area2)
    ok = esign != 0
    zmax = tri[:, :, 2].max(axis=1)
    bx0 = txy[:, :, 0].min(axis=1)
    bx1 = txy[:, :, 0].max(axis=1)
    by0 = txy[:, :, 1].min(axis=1)
    by1 = txy[:, :, 1].max(axis=1)
    if np.any(ok):
        x0, x1 = float(bx0[ok].min()), float(bx1[ok].max())
        y0, y1 = float(by0[ok].min()), float(by1[ok].max())
    else:
        x0 = x1 = y0 = y1 = 0.0
    w = max(x1 - x0, 1e-300)
    h = max(y1 - y0, 1e-300)
    n_ok = max(int(ok.sum()), 1)
    target = min(max(cells_per_face * n_ok, 1.0), _MAX_CELLS)
    # cells of equal aspect; at least one cell per axis
    cell = np.sqrt(w * h / target) if w > 1e-300 and h > 1e-300 else max(w, h) / target
    nx = int(min(max(np.ceil(w / cell), 1), _MAX_CELLS))
    ny = int(min(max(np.ceil(h / cell), 1), max(_MAX_CELLS // nx, 1)))
    cells = (bx0, bx1, by0, by1, x0, y0, float(nx / w), float(ny / h), nx, ny, ok)
    order = np.argsort(-zmax, kind="stable").astype(np.int64)
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    _bin_cells(order, *cells, start[1:], start[:0], True)
    np.cumsum(start, out=start)
    items = np.empty(int(start[-1]), dtype=np.int64)
    _bin_cells(order, *cells, start[:-1].copy(), items, False)
    return np.ascontiguousarray(esign), np.ascontiguousarray(zmax), (x0, y0, float(nx / w), float(ny / h), nx, ny, start, items)


class TopSurface:
    """A triangle mesh seen from above: ``query(xy)`` gives the highest hit under each point.

    vertices (nv, 3) float and faces (nf, 3) int (triangles). Units are the mesh's own
    (SI, metres, by default throughout surfhap). The index is built once, at construction.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, name: str = "mesh", source: str | None = None):
        v, f = check_mesh(vertices, faces, source or name)
        self.vertices = v
        self.faces = f
        self.name = name
        self.source = source
        esign, zmax, grid = _build_grid(v, f)
        if not np.any(esign != 0):
            raise MeshFormatError("no triangle faces upward or downward: nothing can be touched from above",
                                  source=source or name)
        # the mesh and its grid, as every compiled query (hit_one) takes them
        self._args = (v, f, esign, zmax, *grid)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_file(cls, path: str | Path, *, up: str = "z", scale: float = 1.0, size: float | None = None) -> "TopSurface":
        """Load OBJ, STL, PLY, glTF/GLB, OFF... through trimesh; see
        :func:`surfhap.exchange.mesh.read_mesh` for ``up``, ``scale`` and ``size``."""
        from surfhap.exchange.mesh import read_mesh

        m = read_mesh(path, up=up, scale=scale, size=size)
        return cls(m.vertices, m.faces, name=m.name, source=m.source)

    @classmethod
    def from_trimesh(cls, mesh, *, name: str | None = None) -> "TopSurface":
        """From a ``trimesh.Trimesh`` (or a Scene, whose geometry is concatenated)."""
        from surfhap.exchange.mesh import arrays_from_trimesh

        v, f = arrays_from_trimesh(mesh, source=name or "trimesh mesh")
        return cls(v, f, name=name or "mesh")

    # ------------------------------------------------------------------ queries
    def query(self, xy: np.ndarray) -> TopHits:
        """Highest hits under the points ``xy`` (n, 2) float: ``TopHits(z (n,), face (n,))``,
        NaN / -1 where the vertical ray misses the mesh."""
        xy = np.ascontiguousarray(xy, dtype=np.float64)
        if xy.ndim != 2 or xy.shape[1] != 2:
            raise ValueError(f"xy must be an (n, 2) array, got shape {xy.shape}")
        z, f = np.empty(xy.shape[0]), np.empty(xy.shape[0], dtype=np.int64)
        _query_kernel(xy, *self._args, z, f)
        return TopHits(z, f)

    def query_normals(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Like :meth:`query`, plus the hit faces' upward unit normals: ``(z (n,), face (n,),
        normal (n, 3))``, NaN rows off the mesh."""
        z, f = self.query(xy)
        return z, f, self.normals_of(f)

    def query_point(self, x: float, y: float) -> tuple[float, int]:
        """One point: ``(z, face)``, ``(nan, -1)`` off the mesh. The cheapest call for a live loop."""
        z, f = hit_one(float(x), float(y), *self._args)
        return (z if f >= 0 else np.nan), f

    def normals_of(self, face: np.ndarray) -> np.ndarray:
        """(n, 3) unit normals, oriented upward (nz >= 0), of the faces ``face`` (n,) int;
        NaN rows for -1."""
        face = np.asarray(face, dtype=np.int64)
        out = self.up_normals[np.clip(face, 0, None)]
        out = np.where((face >= 0)[:, None], out, np.nan)
        return out

    # ------------------------------------------------------------------ geometry
    @cached_property
    def normals(self) -> np.ndarray:
        """(nf, 3) unit face normals from the winding (zero rows for degenerate faces)."""
        tri = self.vertices[self.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(n, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            n = np.where(norm[:, None] > 0, n / norm[:, None], 0.0)
        return n

    @cached_property
    def up_normals(self) -> np.ndarray:
        """(nf, 3) unit face normals flipped to point up (nz >= 0): the side a finger touches."""
        n = self.normals
        return np.where(n[:, 2:3] < 0, -n, n)

    @cached_property
    def centroids(self) -> np.ndarray:
        """(nf, 3) face centroids."""
        return self.vertices[self.faces].mean(axis=1)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float: lower and upper corner of the bounding box."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    @cached_property
    def top_faces(self) -> np.ndarray:
        """(nf,) bool: faces a finger can reach, i.e. the highest hit at their own centroid."""
        _, f = self.query(self.centroids[:, :2])
        top = np.zeros(self.n_faces, dtype=bool)
        top[f[f >= 0]] = True
        return top

    @cached_property
    def theta_min(self) -> float:
        """Smallest convex dihedral angle (degrees) between adjacent top faces; the
        θmin of Kim et al. eq. 10. 0.0 when the top surface has no convex edge."""
        from surfhap.shape.edges import smallest_convex_dihedral

        return smallest_convex_dihedral(self)

    def __repr__(self) -> str:
        return f"TopSurface({self.name!r}, {self.vertices.shape[0]} vertices, {self.n_faces} faces)"
