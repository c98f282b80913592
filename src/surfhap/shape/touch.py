"""The touch-rate step of shape rendering for one touch sample (compiled, scalar).

:func:`touch_step` chains the three parts of Kim et al. (2017) Sec. 4 for one new finger
position: the vertical ray onto the mesh (:func:`surfhap.shape.raycast.hit_one`), the
gradient force and intensity (eq. 3-9, :func:`surfhap.shape.gradient.gradient_step`) and the
edge tick (eq. 10-11, :func:`surfhap.shape.edges.edge_tick_one`). :func:`touch_block` loops it
over a block of samples. The offline renderer (``ShapeRenderer``) runs ``touch_block``; the
live renderer calls ``touch_step`` once per new position; both therefore give bit-identical
intensities and ticks for the same positions.

The chain state between samples is one (5,) float array ``state = (x, y, z, force, face)``
of the previous sample (NaN position, force 0, face -1 at the start of a chain): see
:func:`new_state`.
"""

from __future__ import annotations

import numba
import numpy as np

from surfhap.shape.edges import edge_tick_one
from surfhap.shape.gradient import check_range, gradient_step
from surfhap.shape.raycast import hit_one

__all__ = ["touch_step", "touch_block", "new_state"]


def new_state() -> np.ndarray:
    """(5,) float chain state with no previous sample: (NaN, NaN, NaN, 0 N, face -1)."""
    return np.array([np.nan, np.nan, np.nan, 0.0, -1.0])


@numba.njit(cache=True, nogil=True)
def touch_step(x, y, state, fz, fmin, fmax, edges, theta_min, threshold_deg, normals,
               verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items):
    """One touch sample at (x, y) (m, mesh coordinates; NaN = not touching).

    state (5,) float: previous (x, y, z, force, face), updated in place. fz (N), fmin < fmax
    (sqrt(N)): eq. 6-9. edges: compute edge ticks; theta_min, threshold_deg (deg): eq. 10-11.
    normals (nf, 3) float up normals; the rest is the mesh and its grid
    (``TopSurface._args``). Returns ``(z, face, force, fsq, intensity, tick, theta)``: z NaN
    and face -1 off the mesh; tick 0 and theta NaN where no face change was met.
    """
    z, f = hit_one(x, y, verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items)
    if f < 0:
        z = np.nan
    force, fsq, inten, _ = gradient_step(x, y, z, state[0], state[1], state[2], state[3], fz, fmin, fmax)
    tick = 0.0
    theta = np.nan
    if edges:
        tick, theta = edge_tick_one(normals, int(state[4]), f, state[0], state[1], state[2], x, y, z,
                                    theta_min, threshold_deg)
    state[0] = x
    state[1] = y
    state[2] = z
    state[3] = force
    state[4] = f
    return z, f, force, fsq, inten, tick, theta


@numba.njit(cache=True, nogil=True)
def _touch_loop(x, y, state, fz, fmin, fmax, edges, theta_min, threshold_deg, normals,
                verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items,
                z_out, face_out, force_out, fsq_out, inten_out, tick_out, theta_out):
    for i in range(x.shape[0]):
        (z_out[i], face_out[i], force_out[i], fsq_out[i], inten_out[i], tick_out[i],
         theta_out[i]) = touch_step(x[i], y[i], state, fz, fmin, fmax, edges, theta_min, threshold_deg, normals,
                                    verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items)


def touch_block(surface, x: np.ndarray, y: np.ndarray, state: np.ndarray, *, fz: float, fmin: float, fmax: float,
                edges: bool, theta_min: float, threshold_deg: float):
    """:func:`touch_step` over (n,) float positions x, y (m; NaN = not touching).

    ``surface`` a :class:`~surfhap.shape.topsurface.TopSurface`; ``state`` (5,) float,
    updated in place. Returns ``(z, face, force, fsq, intensity, tick, theta)``, each (n,)
    (face int64).
    """
    fmin, fmax = check_range(fmin, fmax)
    if edges and not theta_min < 180.0:
        raise ValueError(f"theta_min must be below 180 deg, got {theta_min}")
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    n = x.shape[0]
    out = [np.empty(n) for _ in range(7)]
    out[1] = np.empty(n, dtype=np.int64)
    _touch_loop(x, y, state, float(fz), fmin, fmax, bool(edges), float(theta_min), float(threshold_deg),
                surface.up_normals, *surface._args, *out)
    return tuple(out)
