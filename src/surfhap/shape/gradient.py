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
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FZ_DEFAULT",
    "I_MIN",
    "I_MAX",
    "lateral_force",
    "signed_sqrt",
    "intensity_from_fsq",
    "neutral_intensity",
]

FZ_DEFAULT = 1.0  # N, assumed normal force (Kim et al. Sec. 3.1.1 and eq. 7)
I_MAX = 1.0  # intensity for Fsq <= Fsq_min (eq. 9)
I_MIN = 0.3  # weakest clearly perceptible intensity (Sec. 4.1, eq. 9)


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
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    z = np.asarray(z, dtype=float)
    n = x.shape[0]
    if prev is None:
        px, py, pz, pf = np.nan, np.nan, np.nan, 0.0
    else:
        px, py, pz, pf = (float(v) for v in prev)
    xp = np.concatenate(([px], x[:-1])) if n else x
    yp = np.concatenate(([py], y[:-1])) if n else y
    zp = np.concatenate(([pz], z[:-1])) if n else z
    dr = np.hypot(x - xp, y - yp)
    dz = z - zp
    on_both = np.isfinite(z) & np.isfinite(zp)
    moved = on_both & (dr > 0)
    at_rest = ~(dr > 0) & np.isfinite(x) & np.isfinite(xp)  # dr == 0: hold
    if prev is None and n:
        at_rest[0] = False
    with np.errstate(divide="ignore", invalid="ignore"):
        raw = np.where(moved, -fz * dz / np.where(moved, dr, 1.0), 0.0)
    # hold the previous value while at rest: forward-fill from the last non-rest sample
    idx = np.where(at_rest, -1, np.arange(n))
    np.maximum.accumulate(idx, out=idx)
    held = np.where(idx >= 0, raw[np.clip(idx, 0, None)], pf)
    return held, moved


def signed_sqrt(force: np.ndarray) -> np.ndarray:
    """``sgn(F) sqrt(|F|)`` (eq. 8), elementwise."""
    f = np.asarray(force, dtype=float)
    return np.sign(f) * np.sqrt(np.abs(f))


def intensity_from_fsq(fsq: np.ndarray, fmin: float, fmax: float) -> np.ndarray:
    """Eq. 9: map Fsq in [fmin, fmax] linearly onto intensity [1.0, 0.3], saturating outside.

    fsq (n,) float; fmin < fmax. NaN inputs give the intensity of Fsq = 0. The result is
    always within [0.3, 1.0].
    """
    fmin = float(fmin)
    fmax = float(fmax)
    if not (np.isfinite(fmin) and np.isfinite(fmax) and fmin < fmax):
        raise ValueError(f"need finite fmin < fmax, got ({fmin}, {fmax})")
    f = np.nan_to_num(np.asarray(fsq, dtype=float), nan=0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        i = ((I_MAX - I_MIN) * f + I_MIN * fmin - I_MAX * fmax) / (fmin - fmax)
    i = np.where(f <= fmin, I_MAX, np.where(f >= fmax, I_MIN, i))
    return np.clip(i, I_MIN, I_MAX)


def neutral_intensity(fmin: float, fmax: float) -> float:
    """Intensity of a flat surface (Fsq = 0) under eq. 9."""
    return float(intensity_from_fsq(np.zeros(1), fmin, fmax)[0])
