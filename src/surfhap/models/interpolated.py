"""ARMA texture models interpolated over (scan speed, normal force) in the LSF domain.

This is the model of the Penn Haptic Texture Toolkit (HaTT; Culbertson et al.) used by
Zhao et al.: a set of ARMA models, each labelled with the speed and force of the recording
segment it came from, a Delaunay triangulation over the (speed, force) vertices, and at
render time::

    1. clamp: speed to max_speed - 0.01 mm/s, force to max_force - 0.01 N; speeds below
       0.05 mm/s and forces below 0.05 N are set to 0 (onto the zero-variance edge models);
    2. find the triangle holding (speed, force), barycentric weights w (3,);
    3. interpolate the AR and MA line spectral frequencies, the excitation variance and the
       MA gain linearly with w (stable by construction, see :mod:`surfhap.signal.lsf`);
    4. y[n] = -sum_i a_i y[n-i] + gain (e[n] + sum_j b_j e[n-j]),  e ~ N(0, variance).

The output and excitation histories are kept across model changes (HaTT keeps one history
per texture and only swaps the coefficients). A query outside every triangle (possible when
the hull is not a rectangle) uses the nearest vertex's model; degenerate triangles (collinear
vertices) are ignored.

The bank is a :class:`surfhap.models.texture.TextureModel` (the texture interface of a
Material): ``synthesizer(seed)`` whose ``process(speed, load)`` takes speed (m/s) and normal
force (N) blocks, and ``psd_at`` / ``moments_at`` of the model at a (speed, force).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import numba
import numpy as np
from pydantic import BeforeValidator, Field, field_validator, model_validator

from surfhap.checked import FiniteArray, checked_dataclass
from surfhap.signal.ar import ar_moments, ar_psd
from surfhap.signal.lsf import _lsf_to_poly_into, lsf_is_valid, lsf_to_poly

__all__ = ["InterpolatedARMABank", "InterpolatedModel", "InterpolatedSynthesizer", "MIN_SPEED", "MIN_FORCE"]

#: m/s and N: below these the query is set to 0 (HaTT)
MIN_SPEED = 0.05e-3
MIN_FORCE = 0.05
#: clamp margins below the maxima (HaTT: 0.01 mm/s and 0.01 N)
SPEED_MARGIN = 0.01e-3
FORCE_MARGIN = 0.01


@dataclass(frozen=True)
class InterpolatedModel:
    """One interpolated model: A (p + 1,) and B (q + 1,) monic polynomials, variance, gain,
    the triangle (-1 when the nearest vertex was used) and the weights per vertex (3,)."""

    ar_poly: np.ndarray
    ma_poly: np.ndarray
    variance: float
    gain: float
    triangle: int
    vertices: np.ndarray
    weights: np.ndarray

    def _arma(self) -> tuple[np.ndarray, float, np.ndarray]:
        """(phi, innovation variance, theta) of :func:`~surfhap.signal.ar.ar_psd`: the output
        is gain (e + sum b_j e[n-j]), so the innovation is gain e."""
        return -self.ar_poly[1:], self.variance * self.gain**2, self.ma_poly[1:]

    def psd(self, sample_rate: float, freqs: np.ndarray) -> np.ndarray:
        """One-sided PSD: 2 var gain^2 |B|^2 / |A|^2 / fs at freqs (m,) Hz."""
        phi, var, theta = self._arma()
        return ar_psd(phi, var, sample_rate, freqs, theta)


def _triangle_transforms(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(t, 2, 2) inverse edge matrices for barycentric coordinates. A degenerate triangle
    (collinear vertices; it contains no point) gets NaN, so it never matches a query."""
    p = points[triangles]
    m = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=-1)  # columns: the edges from vertex 0
    scale = np.maximum(np.abs(m).max(axis=(1, 2), initial=0.0), 1e-300)
    ok = np.abs(np.linalg.det(m / scale[:, None, None])) >= 1e-12
    out = np.full(m.shape, np.nan)
    out[ok] = np.linalg.inv(m[ok])
    return out


@numba.njit(cache=True, nogil=True)
def _clamp(speed, force, limits):
    """The HaTT clamp (module docstring, step 1) of one speed m/s and force N; NaN counts as 0.
    limits: max_speed, max_force, min_speed, min_force (after the margins), scale_x, scale_y."""
    x = min(abs(speed), limits[0]) if speed == speed else 0.0
    y = min(force, limits[1]) if force == force else 0.0
    return (0.0 if x < limits[2] else x), (0.0 if y < limits[3] else y)


@numba.njit(cache=True, nogil=True)
def _vertices(x, y, pts, tris, inv, start, limits):
    """(triangle, i0, i1, i2, w0, w1, w2): the vertices of the triangle holding the clamped
    (x, y) (triangle ``start`` tried first) and their barycentric weights, or triangle -1 and
    the nearest vertex (distances scaled by limits[4:6]) with weight 1."""
    for kk in range(tris.shape[0] + 1):
        k = start if kk == 0 else kk - 1
        if k < 0 or (kk > 0 and k == start):
            continue
        i0 = tris[k, 0]
        dx = x - pts[i0, 0]
        dy = y - pts[i0, 1]
        l1 = inv[k, 0, 0] * dx + inv[k, 0, 1] * dy
        l2 = inv[k, 1, 0] * dx + inv[k, 1, 1] * dy
        l0 = 1.0 - l1 - l2
        if l0 >= -1e-9 and l1 >= -1e-9 and l2 >= -1e-9:
            return k, i0, tris[k, 1], tris[k, 2], l0, l1, l2
    best = 0
    bd = 1e300
    for i in range(pts.shape[0]):
        d = ((x - pts[i, 0]) / limits[4]) ** 2 + ((y - pts[i, 1]) / limits[5]) ** 2
        if d < bd:
            bd = d
            best = i
    return -1, best, best, best, 1.0, 0.0, 0.0


@numba.njit(cache=True, nogil=True)
def _synth_kernel(speed, force, z, pts, tris, inv, ar_lsf, ma_lsf, var, gain, limits, yh, eh, state, out,
                  lsf_a, lsf_b, poly_a, poly_b, wa1, wa2, wb1, wb2):
    # state: [last_tri, last_x, last_y, cur_var, cur_gain, ypos, epos]
    n = speed.shape[0]
    p = ar_lsf.shape[1]
    q = ma_lsf.shape[1]
    last_tri = int(state[0])
    last_x = state[1]
    last_y = state[2]
    cur_var = state[3]
    cur_gain = state[4]
    for t in range(n):
        x, yv = _clamp(speed[t], force[t], limits)
        if x != last_x or yv != last_y:
            k, i0, i1, i2, l0, l1, l2 = _vertices(x, yv, pts, tris, inv, last_tri, limits)
            if k >= 0:
                last_tri = k
            for j in range(p):
                lsf_a[j] = l0 * ar_lsf[i0, j] + l1 * ar_lsf[i1, j] + l2 * ar_lsf[i2, j]
            for j in range(q):
                lsf_b[j] = l0 * ma_lsf[i0, j] + l1 * ma_lsf[i1, j] + l2 * ma_lsf[i2, j]
            cur_var = l0 * var[i0] + l1 * var[i1] + l2 * var[i2]
            cur_gain = l0 * gain[i0] + l1 * gain[i1] + l2 * gain[i2]
            _lsf_to_poly_into(lsf_a, poly_a, wa1, wa2)
            _lsf_to_poly_into(lsf_b, poly_b, wb1, wb2)
            last_x = x
            last_y = yv
        e = np.sqrt(max(cur_var, 0.0)) * z[t]
        acc = 0.0
        for i in range(p):
            acc -= poly_a[i + 1] * yh[i]
        ma = e
        for j in range(q):
            ma += poly_b[j + 1] * eh[j]
        acc += cur_gain * ma
        for i in range(p - 1, 0, -1):
            yh[i] = yh[i - 1]
        if p > 0:
            yh[0] = acc
        for j in range(q - 1, 0, -1):
            eh[j] = eh[j - 1]
        if q > 0:
            eh[0] = e
        out[t] = acc
    state[0] = last_tri
    state[1] = last_x
    state[2] = last_y
    state[3] = cur_var
    state[4] = cur_gain


@checked_dataclass
class InterpolatedARMABank:
    """LSF-interpolated ARMA models over (speed, force) (see the module docstring).

    quantity    : "acceleration" (m/s^2; HaTT) or "cof".
    sample_rate : control rate, Hz (HaTT: 1000).
    speeds      : (k,) m/s and forces (k,) N of the vertices (one per model).
    ar_lsf      : (k, p) rad; ma_lsf (k, q) rad (q may be 0).
    variances   : (k,) excitation variances; gains (k,) MA gains.
    triangles   : (t, 3) int, 0-based vertex indices.
    max_speed   : m/s and max_force N, the clamp limits.
    """

    quantity: Literal["acceleration", "cof"]
    sample_rate: Annotated[float, Field(gt=0, allow_inf_nan=False)]
    speeds: FiniteArray
    forces: FiniteArray
    ar_lsf: FiniteArray
    ma_lsf: FiniteArray
    variances: FiniteArray
    gains: FiniteArray
    triangles: Annotated[np.ndarray, BeforeValidator(lambda v: np.ascontiguousarray(np.asarray(v, dtype=np.int64).reshape(-1, 3)))]
    max_speed: Annotated[float, Field(gt=0)]
    max_force: Annotated[float, Field(gt=0)]

    @field_validator("speeds", "forces", "gains", "variances")
    @classmethod
    def _vector(cls, v, info):
        v = v.reshape(-1)
        if info.field_name == "variances" and np.any(v < 0):
            raise ValueError("must be >= 0")
        return v

    @model_validator(mode="after")
    def _models(self):
        k = self.speeds.size
        if k < 1:
            raise ValueError("an interpolated bank needs at least one model")
        for name in ("forces", "variances", "gains"):
            if getattr(self, name).size != k:
                raise ValueError(f"{name} has {getattr(self, name).size} values, expected {k} (one per model)")
        ar = np.ascontiguousarray(self.ar_lsf.reshape(k, -1))
        ma = np.ascontiguousarray(self.ma_lsf.reshape(k, -1) if self.ma_lsf.size else np.zeros((k, 0)))
        tris = self.triangles
        for i in range(k):
            for label, lsf in (("AR", ar[i]), ("MA", ma[i])):
                if not lsf_is_valid(lsf):
                    raise ValueError(f"model {i}: {label} line spectral frequencies must increase strictly within (0, pi)")
        if tris.size and (tris.min() < 0 or tris.max() >= k):
            raise ValueError(f"triangle vertex indices must be within 0..{k - 1}")
        pts = np.ascontiguousarray(np.column_stack([self.speeds, self.forces]))
        inv = _triangle_transforms(pts, tris)
        for key, val in (("ar_lsf", ar), ("ma_lsf", ma), ("_pts", pts), ("_inv", inv)):
            object.__setattr__(self, key, val)
        return self

    # ---- TextureModel (shared with TextureBank) -------------------------------------------
    @property
    def ar_order(self) -> int:
        return int(self.ar_lsf.shape[1])

    @property
    def ma_order(self) -> int:
        return int(self.ma_lsf.shape[1])

    @property
    def max_order(self) -> int:
        return max(self.ar_order, self.ma_order)

    def synthesizer(self, seed=0) -> "InterpolatedSynthesizer":
        return InterpolatedSynthesizer(self, seed=seed)

    # ---- evaluation -----------------------------------------------------------------------
    @property
    def limits(self) -> np.ndarray:
        sx = max(float(np.ptp(self.speeds)), 1e-6)
        sy = max(float(np.ptp(self.forces)), 1e-6)
        return np.array([self.max_speed - SPEED_MARGIN, self.max_force - FORCE_MARGIN, MIN_SPEED, MIN_FORCE, sx, sy])

    def interpolate(self, speed: float, force: float) -> InterpolatedModel:
        """The interpolated model at one (speed m/s, force N), after the clamp."""
        lim = self.limits
        x, y = _clamp(float(speed), float(force), lim)
        k, *idx, w0, w1, w2 = _vertices(x, y, self._pts, self.triangles, self._inv, -1, lim)
        idx, w = np.array(idx), np.array([w0, w1, w2])
        ar = w @ self.ar_lsf[idx]
        return InterpolatedModel(lsf_to_poly(ar), lsf_to_poly(w @ self.ma_lsf[idx]), float(w @ self.variances[idx]), float(w @ self.gains[idx]),
                                 int(k), idx, w)

    def psd_at(self, speed: float, load: float, freqs: np.ndarray) -> np.ndarray:
        """One-sided PSD (quantity^2/Hz) of the interpolated model at (speed, force)
        (:class:`~surfhap.models.texture.TextureModel`)."""
        return self.interpolate(speed, load).psd(self.sample_rate, freqs)

    def moments_at(self, speed: np.ndarray, load: np.ndarray) -> np.ndarray:
        """(2, n) sd and slope sd of the interpolated model at each (speed, force) (n,)."""
        models = (self.interpolate(v, f)._arma() for v, f in zip(np.ravel(speed), np.ravel(load)))
        return np.array([ar_moments(phi, var, self.sample_rate, theta) for phi, var, theta in models]).T

    @classmethod
    def from_models(cls, quantity, sample_rate, speeds, forces, ar_lsf, variances, ma_lsf=None, gains=None,
                    triangles=None, max_speed=None, max_force=None) -> "InterpolatedARMABank":
        """Build a bank; without ``triangles`` a Delaunay triangulation (scipy) is made in
        coordinates scaled by the speed and force ranges."""
        speeds = np.asarray(speeds, dtype=float)
        forces = np.asarray(forces, dtype=float)
        k = speeds.size
        if triangles is None:
            from scipy.spatial import Delaunay

            pts = np.column_stack([speeds / max(np.ptp(speeds), 1e-12), forces / max(np.ptp(forces), 1e-12)])
            triangles = Delaunay(pts).simplices if k >= 3 else np.zeros((0, 3), dtype=np.int64)
        return cls(quantity, float(sample_rate), speeds, forces, np.asarray(ar_lsf, dtype=float),
                   np.zeros((k, 0)) if ma_lsf is None else np.asarray(ma_lsf, dtype=float), np.asarray(variances, dtype=float),
                   np.ones(k) if gains is None else np.asarray(gains, dtype=float), np.asarray(triangles),
                   float(max_speed if max_speed is not None else speeds.max()),
                   float(max_force if max_force is not None else forces.max()))


class InterpolatedSynthesizer:
    """Streaming synthesis over an :class:`InterpolatedARMABank` at its control rate.

    ``process(speed, load)``: speed (n,) m/s and normal force (n,) N -> (n,) samples. The
    model is re-interpolated whenever (speed, force) changes; histories persist across
    changes and blocks. Same seed, same output, whatever the block sizes.
    """

    def __init__(self, bank: InterpolatedARMABank, seed: int | np.random.Generator | None = 0, max_block: int = 1 << 16):
        self.bank = bank
        self._seed = seed
        p, q = bank.ar_order, bank.ma_order
        self.max_block = int(max_block)
        self._yh = np.zeros(max(p, 1))
        self._eh = np.zeros(max(q, 1))
        self._state = np.zeros(7)
        self._lsf_a = np.zeros(p)
        self._lsf_b = np.zeros(q)
        self._poly_a = np.zeros(p + 1)
        self._poly_b = np.zeros(q + 1)
        self._w = [np.zeros(p + 3), np.zeros(p + 3), np.zeros(q + 3), np.zeros(q + 3)]
        self._noise = np.empty(self.max_block)
        self._limits = bank.limits
        self.reset()

    def reset(self) -> None:
        """Clear histories, forget the current model, restart the noise from the seed."""
        seed = self._seed
        self._rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self._yh[:] = 0.0
        self._eh[:] = 0.0
        self._state[:] = [-1, np.nan, np.nan, 0.0, 1.0, 0, 0]
        self._poly_a[:] = 0.0
        self._poly_a[0] = 1.0
        self._poly_b[:] = 0.0
        self._poly_b[0] = 1.0

    def process(self, speed: np.ndarray, load: np.ndarray | None = None) -> np.ndarray:
        speed = np.ascontiguousarray(speed, dtype=np.float64)
        n = speed.shape[0]
        force = np.zeros(n) if load is None else np.ascontiguousarray(np.broadcast_to(load, (n,)), dtype=np.float64)
        if n > self.max_block:
            return np.concatenate([self.process(speed[i : i + self.max_block], force[i : i + self.max_block])
                                   for i in range(0, n, self.max_block)])
        z = self._noise[:n]
        self._rng.standard_normal(out=z)
        out = np.empty(n)
        b = self.bank
        _synth_kernel(speed, force, z, b._pts, b.triangles, b._inv, b.ar_lsf, b.ma_lsf, b.variances, b.gains, self._limits,
                      self._yh, self._eh, self._state, out, self._lsf_a, self._lsf_b, self._poly_a, self._poly_b, *self._w)
        return out
