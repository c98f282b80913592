"""Gradient rendering of a touched surface (Kim et al. 2017, Sec. 4.1, eq. 3-9).

From consecutive hit points P1 = (x1, y1, z1) and P2 = (x2, y2, z2):

* slope ``tan(alpha) = dz / dr`` with ``dz = z2 - z1`` and ``dr = |(x2 - x1, y2 - y1)|``
  (eq. 3-5);
* lateral force ``F = -Fz tan(alpha)`` with the assumed normal force ``Fz = 1 N`` (eq. 6-7;
  Sec. 3.1.1: no force sensor, 1 N from pilot experiments): negative while climbing
  (resisting), positive while descending (assisting);
* signed square root ``Fsq = sgn(F) sqrt(|F|)`` (eq. 8), because the display's force grows
  with the square of its input;
* intensity: [Fsq_min, Fsq_max] mapped linearly onto [1.0, 0.3], saturating outside
  (eq. 9): the most resisting force gets full intensity, the most assisting one the weakest
  intensity that is still clearly felt (0.3, Sec. 4.1).

A finger at rest (dr = 0) keeps the previous force instead of dividing by zero. Where either
hit point is off the mesh (z NaN) there is no surface to climb: the force is 0 (flat).

One implementation: :func:`gradient_step` is the compiled scalar kernel of eq. 3-9 for one
touch sample. The offline renderer (through :func:`gradient_block`), the calibration scans
(:mod:`surfhap.shape.calibration`) and the live touch step (:mod:`surfhap.shape.touch`) all
call it; the array functions below are loops over its parts. Kernels compile on first call
(``cache=True``), never at import.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "FZ_DEFAULT",
    "I_MIN",
    "I_MAX",
    "gradient_step",
    "gradient_block",
    "lateral_force",
    "signed_sqrt",
    "intensity_from_fsq",
    "check_range",
]

FZ_DEFAULT = 1.0  # N, assumed normal force (Kim et al. Sec. 3.1.1 and eq. 7)
I_MAX = 1.0  # intensity for Fsq <= Fsq_min (eq. 9)
I_MIN = 0.3  # weakest clearly perceptible intensity (Sec. 4.1, eq. 9)


@numba.njit(cache=True, nogil=True)
def _signed_sqrt_one(force):
    # eq. 8
    if force > 0.0:
        return math.sqrt(force)
    if force < 0.0:
        return -math.sqrt(-force)
    return force  # 0, -0 or NaN


@numba.njit(cache=True, nogil=True)
def _intensity_one(fsq, fmin, fmax):
    # eq. 9, saturating outside [fmin, fmax]; NaN counts as Fsq = 0
    f = 0.0 if fsq != fsq else fsq
    if f <= fmin:
        return I_MAX
    if f >= fmax:
        return I_MIN
    i = ((I_MAX - I_MIN) * f + I_MIN * fmin - I_MAX * fmax) / (fmin - fmax)
    return min(max(i, I_MIN), I_MAX)


@numba.njit(cache=True, nogil=True)
def gradient_step(x, y, z, px, py, pz, pforce, fz, fmin, fmax):
    """Eq. 3-9 for one touch sample (the one kernel of every shape path).

    x, y  : m, touch position; z: m, its hit height (NaN off the mesh).
    px, py, pz, pforce : the previous sample's position, height and force (N); NaN
            position at the start of a chain (after a lift), with ``pforce`` 0.
    fz    : N, assumed normal force; fmin < fmax: sqrt(N), the calibrated Fsq range.
    Returns ``(force N, fsq sqrt(N), intensity in [0.3, 1], moved)``: ``moved`` is True when
    the force came from a real step (dr > 0 with both hits on the mesh); at rest (dr = 0,
    both positions finite) the previous force is held; otherwise the force is 0.
    """
    dr = math.hypot(x - px, y - py)
    moved = False
    if dr > 0.0:
        if math.isfinite(z) and math.isfinite(pz):
            force = -fz * (z - pz) / dr
            moved = True
        else:
            force = 0.0
    elif math.isfinite(x) and math.isfinite(px):
        force = pforce  # at rest: hold
    else:
        force = 0.0
    fsq = _signed_sqrt_one(force)
    return force, fsq, _intensity_one(fsq, fmin, fmax), moved


@numba.njit(cache=True, nogil=True)
def _gradient_loop(x, y, z, px, py, pz, pf, fz, fmin, fmax, force, fsq, inten, moved):
    for i in range(x.shape[0]):
        f, s, it, mv = gradient_step(x[i], y[i], z[i], px, py, pz, pf, fz, fmin, fmax)
        force[i] = f
        fsq[i] = s
        inten[i] = it
        moved[i] = mv
        px = x[i]
        py = y[i]
        pz = z[i]
        pf = f


def check_range(fmin: float, fmax: float) -> tuple[float, float]:
    """(fmin, fmax) as floats; ValueError unless finite with fmin < fmax (the Fsq range of eq. 9)."""
    fmin = float(fmin)
    fmax = float(fmax)
    if not (np.isfinite(fmin) and np.isfinite(fmax) and fmin < fmax):
        raise ValueError(f"need finite fmin < fmax, got ({fmin}, {fmax})")
    return fmin, fmax


def gradient_block(x: np.ndarray, y: np.ndarray, z: np.ndarray, fmin: float, fmax: float, *, fz: float = FZ_DEFAULT,
                   prev: tuple[float, float, float, float] | None = None):
    """Eq. 3-9 along a sequence of touch samples (a loop over :func:`gradient_step`).

    x, y, z : (n,) float positions (m) and hit heights (m, NaN off the mesh).
    fmin < fmax : sqrt(N), Fsq range of eq. 9; fz: N.
    prev    : (x, y, z, force) of the sample before the block, or None at the start of a
              trajectory (the first sample then gets force 0).
    Returns ``(force (n,) N, fsq (n,) sqrt(N), intensity (n,) in [0.3, 1], moved (n,) bool)``.
    """
    fmin, fmax = check_range(fmin, fmax)
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    z = np.ascontiguousarray(z, dtype=np.float64)
    n = x.shape[0]
    px, py, pz, pf = (np.nan, np.nan, np.nan, 0.0) if prev is None else (float(v) for v in prev)
    force, fsq, inten = np.empty(n), np.empty(n), np.empty(n)
    moved = np.empty(n, dtype=np.bool_)
    _gradient_loop(x, y, z, px, py, pz, pf, float(fz), fmin, fmax, force, fsq, inten, moved)
    return force, fsq, inten, moved


def lateral_force(x: np.ndarray, y: np.ndarray, z: np.ndarray, *, fz: float = FZ_DEFAULT,
                  prev: tuple[float, float, float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Lateral force from consecutive hit points (eq. 3-7).

    x, y, z : (n,) float touch positions and hit heights (z NaN off the mesh).
    fz      : assumed normal force, N.
    prev    : (x, y, z, force) of the sample before the block, or None at the start of a
              trajectory (the first sample then gets force 0).
    Returns ``(force (n,) float N, moved (n,) bool)``: ``moved`` marks samples whose force
    was computed from a real step (dr > 0 on the mesh) rather than held or set to 0.
    """
    force, _, _, moved = gradient_block(x, y, z, -1.0, 1.0, fz=fz, prev=prev)
    return force, moved


@numba.njit(cache=True, nogil=True)
def _sqrt_loop(f, out):
    for i in range(f.shape[0]):
        out[i] = _signed_sqrt_one(f[i])


@numba.njit(cache=True, nogil=True)
def _intensity_loop(f, fmin, fmax, out):
    for i in range(f.shape[0]):
        out[i] = _intensity_one(f[i], fmin, fmax)


def signed_sqrt(force: np.ndarray) -> np.ndarray:
    """``sgn(F) sqrt(|F|)`` (eq. 8), elementwise over an (n,) float array."""
    f = np.ascontiguousarray(force, dtype=np.float64).ravel()
    out = np.empty_like(f)
    _sqrt_loop(f, out)
    return out.reshape(np.shape(force))


def intensity_from_fsq(fsq: np.ndarray, fmin: float, fmax: float) -> np.ndarray:
    """Eq. 9: map Fsq in [fmin, fmax] linearly onto intensity [1.0, 0.3], saturating outside.

    fsq (n,) float; fmin < fmax. NaN inputs give the intensity of Fsq = 0. The result is
    always within [0.3, 1.0].
    """
    fmin, fmax = check_range(fmin, fmax)
    f = np.ascontiguousarray(fsq, dtype=np.float64).ravel()
    out = np.empty_like(f)
    _intensity_loop(f, fmin, fmax, out)
    return out.reshape(np.shape(fsq))
