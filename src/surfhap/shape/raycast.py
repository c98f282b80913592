"""The vertical ray test of one point against a binned triangle mesh (compiled, scalar).

:func:`hit_one` is the innermost step of every shape query: the top-surface index
(:mod:`surfhap.shape.topsurface`), the calibration scans (:mod:`surfhap.shape.calibration`),
edge walking (:mod:`surfhap.shape.edges`) and the live touch step
(:mod:`surfhap.shape.touch`). It lives in its own module so all of them import it from
here and none imports another's private helper (the grid layout is documented in
:mod:`surfhap.shape.topsurface`).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["hit_one"]


@numba.njit(cache=True, nogil=True, inline="always")
def hit_one(px, py, verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items):
    """Highest hit of the vertical ray at (px, py) (mesh units, m).

    verts (nv, 3) float, faces (nf, 3) int64, esign (nf,) float orientation of each face's xy
    projection (0 = vertical, never hit), zmax (nf,) float; x0, y0, inv_cw, inv_ch, nx, ny,
    start (nx*ny + 1,) int64, items (k,) int64: the grid of
    :func:`surfhap.shape.topsurface._build_grid`. Returns ``(z, face)``; ``(-inf, -1)`` when
    the ray misses (NaN or infinite coordinates miss).
    """
    best_z = -np.inf
    best_f = -1
    fx = (px - x0) * inv_cw
    fy = (py - y0) * inv_ch
    if not (fx >= 0.0 and fx <= nx and fy >= 0.0 and fy <= ny):  # also rejects NaN and inf
        return best_z, best_f
    i = int(fx)
    j = int(fy)
    # points exactly on the far border belong to the last cell
    if i == nx:
        i = nx - 1
    if j == ny:
        j = ny - 1
    c = j * nx + i
    for k in range(start[c], start[c + 1]):
        f = items[k]
        if zmax[f] < best_z:
            break
        a = faces[f, 0]
        b = faces[f, 1]
        d = faces[f, 2]
        ax = verts[a, 0]
        ay = verts[a, 1]
        bx = verts[b, 0]
        by = verts[b, 1]
        dx = verts[d, 0]
        dy = verts[d, 1]
        # edge functions with canonical vertex order; esign restores the face's orientation
        if a < b:
            e2 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
        else:
            e2 = -((ax - bx) * (py - by) - (ay - by) * (px - bx))
        if b < d:
            e0 = (dx - bx) * (py - by) - (dy - by) * (px - bx)
        else:
            e0 = -((bx - dx) * (py - dy) - (by - dy) * (px - dx))
        if d < a:
            e1 = (ax - dx) * (py - dy) - (ay - dy) * (px - dx)
        else:
            e1 = -((dx - ax) * (py - ay) - (dy - ay) * (px - ax))
        s = esign[f]
        e0 *= s
        e1 *= s
        e2 *= s
        if e0 < 0.0 or e1 < 0.0 or e2 < 0.0:
            continue
        tot = e0 + e1 + e2
        if tot <= 0.0:
            continue
        z = (e0 * verts[a, 2] + e1 * verts[b, 2] + e2 * verts[d, 2]) / tot
        if z > best_z:
            best_z = z
            best_f = f
    return best_z, best_f
