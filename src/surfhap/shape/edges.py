"""Edge emphasis (Kim et al. 2017, Sec. 4.3, eq. 10-11).

Each time the finger's hit point moves from face f1 to another face f2, the dihedral angle
theta between the two faces is computed from their normals. Seen from above (normals oriented
up, the side a finger touches), with phi the angle between the normals:

* the edge is *convex* when the surface bends down, i.e. ``(n1 - n2) . (P2 - P1) < 0``
  (P2 lies under the plane of f1 and P1 under the plane of f2); then theta = 180 deg - phi;
* otherwise it is concave (theta = 180 deg + phi) and, as in the paper, ignored ("concave
  ones are not reachable in reality").

Walking mode (``edge_ticks_walk``, an extension): the paper compares only the faces of
consecutive hits, so a narrow feature crossed between two touch samples (a step one pixel
wide in a height map) passes unnoticed. In walking mode the segment between the two touch
points is sampled at a spacing finer than the mesh, every face change along it is tested,
and the sharpest qualifying convex edge of the step gives that sample's tick (one tick per
touch sample at most).

A convex edge of angle theta has sharpness ``S = -(theta - 180) / (180 - theta_min)``
(eq. 10), with theta_min the smallest convex dihedral angle of the object, and is played as a
tick of intensity ``Ie = 0.7 S + 0.3`` (eq. 11).

Which edges tick: the paper highlights every convex edge and marks those with theta < 135 deg
as "relatively sharp" (Fig. 10). On a finely tessellated smooth surface every face change is
a slightly convex edge, which would turn a smooth bump into a stream of weak ticks, so
surfhap ticks only for edges with theta <= ``threshold_deg``, by default those 135 deg; pass
``threshold_deg=180`` for every convex edge, as in the paper's text. theta_min is measured
over adjacent pairs of faces that a finger can reach from above (see
:attr:`TopSurface.top_faces`); when the object has no convex edge it is 0 deg. S is clipped
to [0, 1] (non-adjacent faces hit in consecutive frames can bend more than any single edge).
"""

from __future__ import annotations

import numba
import numpy as np

from surfhap.shape.raycast import hit_one

__all__ = ["edge_ticks_walk", "walk_spacing", "EDGE_THRESHOLD_DEG", "FLAT_TOLERANCE_DEG", "edge_tick_one",
           "smallest_convex_dihedral"]

EDGE_THRESHOLD_DEG = 135.0  # Kim et al. Fig. 10: convex edges with theta < 135 deg are "relatively sharp"
FLAT_TOLERANCE_DEG = 1e-4  # deg; normals closer than this are coplanar (float noise of arccos near 1 is ~1e-6 deg)


@numba.njit(cache=True, nogil=True)
def edge_tick_one(normals, f1, f2, x1, y1, z1, x2, y2, z2, theta_min, threshold_deg):
    """Eq. 10-11 for one step from hit (x1, y1, z1) on face f1 to (x2, y2, z2) on face f2
    (compiled, scalar: the one form of eq. 10-11 and of the dihedral angle, used by the touch
    step, walking mode and :func:`smallest_convex_dihedral`).

    normals (nf, 3) float up normals; theta_min, threshold_deg in degrees. Returns
    ``(tick, theta)``: the tick intensity Ie (0 unless a convex edge with theta <=
    threshold_deg was crossed) and the dihedral angle (deg; NaN unless the face changed with
    both hits on the mesh).
    """
    if f1 < 0 or f2 < 0 or f1 == f2:
        return 0.0, np.nan
    c = normals[f1, 0] * normals[f2, 0] + normals[f1, 1] * normals[f2, 1] + normals[f1, 2] * normals[f2, 2]
    c = min(1.0, max(-1.0, c))
    phi = np.degrees(np.arccos(c))
    bend = ((normals[f1, 0] - normals[f2, 0]) * (x2 - x1) + (normals[f1, 1] - normals[f2, 1]) * (y2 - y1)
            + (normals[f1, 2] - normals[f2, 2]) * (z2 - z1))
    if not phi > FLAT_TOLERANCE_DEG:
        return 0.0, 180.0
    if not bend < 0.0:
        return 0.0, 180.0 + phi
    theta = 180.0 - phi
    if not theta <= threshold_deg:
        return 0.0, theta
    s = -(theta - 180.0) / (180.0 - theta_min)
    s = min(max(s, 0.0), 1.0)
    return 0.7 * s + 0.3, theta


@numba.njit(cache=True, nogil=True)
def _smallest_convex(adj, normals, centroids):
    # the smallest theta over the face pairs adj (k, 2) whose edge is convex (a tick at threshold 180 deg)
    best = np.inf
    for k in range(adj.shape[0]):
        a, b = adj[k, 0], adj[k, 1]
        tick, theta = edge_tick_one(normals, a, b, centroids[a, 0], centroids[a, 1], centroids[a, 2],
                                    centroids[b, 0], centroids[b, 1], centroids[b, 2], 0.0, 180.0)
        if tick > 0.0 and theta < best:
            best = theta
    return best if best < np.inf else 0.0


def smallest_convex_dihedral(surface) -> float:
    """theta_min (degrees) of a :class:`~surfhap.shape.topsurface.TopSurface`: the smallest
    convex dihedral angle between adjacent faces that both lie on the top surface; 0.0 if
    there is none."""
    import trimesh

    mesh = trimesh.Trimesh(surface.vertices, surface.faces, process=False, validate=False)
    adj = np.asarray(mesh.face_adjacency, dtype=np.int64)
    if adj.size == 0:
        return 0.0
    top = surface.top_faces
    adj = np.ascontiguousarray(adj[top[adj[:, 0]] & top[adj[:, 1]]])
    return float(_smallest_convex(adj, surface.up_normals, np.ascontiguousarray(surface.centroids))) if adj.size else 0.0


def walk_spacing(surface) -> float:
    """Sub-sample spacing (m) for walking mode: half the 5th percentile of the xy lengths of
    the mesh's edges (the small features), at least 1e-6 of the mesh's xy diagonal."""
    v = surface.vertices
    f = surface.faces
    e = np.concatenate([v[f[:, 1], :2] - v[f[:, 0], :2], v[f[:, 2], :2] - v[f[:, 1], :2], v[f[:, 0], :2] - v[f[:, 2], :2]])
    length = np.hypot(e[:, 0], e[:, 1])
    lo, hi = surface.bounds
    diag = float(np.hypot(*(hi[:2] - lo[:2])))
    length = length[length > 1e-9 * max(diag, 1e-300)]
    base = float(np.percentile(length, 5)) / 2.0 if length.size else diag
    return max(base, 1e-6 * diag, 1e-12)


@numba.njit(cache=True, nogil=True)
def _walk_kernel(x, y, face, px0, py0, pf0, spacing, max_sub, normals, theta_min, threshold,
                 verts, faces, esign, zmax, gx0, gy0, inv_cw, inv_ch, nx, ny, start, items, tick, theta_out):
    px = px0
    py = py0
    pf = pf0
    for i in range(x.shape[0]):
        cx = x[i]
        cy = y[i]
        cf = face[i]
        tick[i] = 0.0
        theta_out[i] = np.nan
        if cf >= 0 and pf >= 0 and cf != pf:
            dx = cx - px
            dy = cy - py
            dist = np.sqrt(dx * dx + dy * dy)
            m = int(np.ceil(dist / spacing))
            if m < 1:
                m = 1
            if m > max_sub:
                m = max_sub
            lf = pf
            lx = px
            ly = py
            lz = np.nan
            best_theta = np.nan
            for k in range(1, m + 1):
                sx = px + dx * k / m
                sy = py + dy * k / m
                z, f = hit_one(sx, sy, verts, faces, esign, zmax, gx0, gy0, inv_cw, inv_ch, nx, ny, start, items)
                if f < 0:
                    lf = -1
                    continue
                if lf >= 0 and f != lf:
                    if not np.isfinite(lz):
                        # height of the previous sub-sample on its face is needed for the bend test
                        lz, _ = hit_one(lx, ly, verts, faces, esign, zmax, gx0, gy0, inv_cw, inv_ch, nx, ny, start, items)
                    ie, th = edge_tick_one(normals, lf, f, lx, ly, lz, sx, sy, z, theta_min, threshold)
                    if th != 180.0:  # 180 exactly: coplanar faces, no edge
                        if not (best_theta <= th):
                            best_theta = th
                        if ie > tick[i]:
                            tick[i] = ie
                lf = f
                lx = sx
                ly = sy
                lz = z
            theta_out[i] = best_theta
        px = cx
        py = cy
        pf = cf


def edge_ticks_walk(surface, x: np.ndarray, y: np.ndarray, face: np.ndarray, theta_min: float, *,
                    threshold_deg: float = EDGE_THRESHOLD_DEG, prev: tuple[float, float, int] | None = None,
                    spacing: float | None = None, max_sub: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    """Edge ticks in walking mode (see the module docstring).

    x, y : (n,) float touch points; face (n,) int their hit faces (-1 off the mesh).
    prev : (x, y, face) of the sample before the block, or None.
    spacing : sub-sample spacing, m (default :func:`walk_spacing`); at most ``max_sub``
    sub-samples per step. Returns ``(tick (n,), theta (n,))`` as :func:`edge_ticks`, theta
    being the smallest dihedral angle met along the step.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    face = np.ascontiguousarray(face, dtype=np.int64)
    n = x.shape[0]
    tick = np.zeros(n)
    theta = np.full(n, np.nan)
    if theta_min >= 180.0:
        raise ValueError("theta_min must be below 180 deg")
    px, py, pf = (np.nan, np.nan, -1) if prev is None else (float(prev[0]), float(prev[1]), int(prev[2]))
    sp = float(spacing) if spacing is not None else walk_spacing(surface)
    _walk_kernel(x, y, face, px, py, pf, sp, int(max_sub), surface.up_normals, float(theta_min), float(threshold_deg),
                 *surface._args, tick, theta)
    return tick, theta
