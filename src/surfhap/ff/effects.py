"""The KinesTouch effects (paper 004, Sec. 3) as per-tick processors.

Every effect has ``reset()`` and ``terms(s)``: given the tick state ``s``
(:class:`TickState`) it returns None where it does not apply at the finger, else its terms
of the control law (eq. 8) as a tuple ``(kx, ky, kz, h, ffx, ffy, ffz)``:

* ``kx, ky, kz``   : N/m, the diagonal of its stabilisation matrix K (004 Table 2);
* ``h``            : m, its offset of the normal reference ``X0 + h e_z``;
* ``ffx, ffy, ffz``: N, its feed-forward force (moving force, grating, attraction).

The built-in effects' laws are compiled (:func:`surfhap.ff.effect_kernel.terms`, the one place
each is written): ``packed()`` gives the engine their row and data, and ``terms`` evaluates the
same law for one state. Any other :class:`Effect` (``packed()`` None) runs its ``terms`` in
Python each touched tick, as does a built-in effect over a field that is not packed (a mesh).

An effect alone is its paper law (eqs. 1-5), ``ff + K (X0 + h e_z - X_t)`` (X0 = 0, N in the
device frame of :mod:`surfhap.ff.params`); :meth:`surfhap.ff.engine.FFEngine.merge` merges
several effects into one force (eq. 8). Parameters that vary over the picture come from :mod:`surfhap.ff.fields`
(a NaN value switches the effect off at that point).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

from surfhap.ff import effect_kernel as ek
from surfhap.ff.fields import ConstantField, Field
from surfhap.ff.params import K_MAX

__all__ = ["TickState", "Effect", "Stiffness", "Shape", "Roughness", "Sliding", "Idle", "Attraction"]


class TickState:
    """Everything an effect may read on one haptic tick (mutable, reused every tick).

    t, dt          : s, tick time (the safety stage's own clock, see :mod:`surfhap.ff.engine`) and interval.
    touched        : finger on the screen (and touch stream fresh).
    fx, fy         : m, finger position in content (world) coordinates.
    fvx, fvy       : m/s, finger velocity in the world; ``speed`` its norm.
    fax, fay       : m/s^2, finger acceleration in the world (smoothed).
    load           : N, finger load as reported by the touch source (0 if unknown).
    px, py, pz     : m, screen position X_t relative to the workspace centre X0.
    vx, vy, vz     : m/s, screen velocity.
    """

    __slots__ = ("t", "dt", "touched", "fx", "fy", "fvx", "fvy", "fax", "fay", "speed", "load", "px", "py", "pz", "vx", "vy", "vz")

    def __init__(self):
        self.t = 0.0
        self.dt = 1e-3
        self.touched = False
        self.fx = self.fy = self.fvx = self.fvy = self.fax = self.fay = self.speed = self.load = 0.0
        self.px = self.py = self.pz = self.vx = self.vy = self.vz = 0.0

    @classmethod
    def of(cls, T: np.ndarray) -> "TickState":
        """The state held in the engine's tick array ``T`` (its first fields, in slot order)."""
        s = cls()
        for k, v in zip(cls.__slots__, T.tolist()):
            setattr(s, k, v)
        s.touched = s.touched != 0.0
        return s

    def array(self) -> np.ndarray:
        """This state as the compiled laws read it (slot order)."""
        return np.array([float(getattr(self, k)) for k in self.__slots__])


def _field(v) -> Field:
    return v if isinstance(v, Field) else ConstantField(float(v))


class Effect(ABC):
    """Base class; subclasses set ``name`` and implement :meth:`terms`. ``vibration``: the
    effect's offset ``h`` is a vibration that bypasses the reference rate limit (Roughness)."""

    name = "effect"
    vibration = False

    def __init__(self, k_max: float = K_MAX):
        self.k_max = float(k_max)
        self.reset()

    def reset(self) -> None:
        """Back to the start (an effect with state overrides it)."""

    def packed(self) -> tuple[np.ndarray, np.ndarray | None] | None:
        """The compiled layout ``(E row, data)`` (:mod:`surfhap.ff.effect_kernel`), None: Python only."""
        return None

    @abstractmethod
    def terms(self, s: TickState):
        """None (not here) or ``(kx, ky, kz, h, ffx, ffy, ffz)`` for this tick."""


class _Compiled(Effect):
    """A built-in effect: its law is :func:`surfhap.ff.effect_kernel.terms` of its ``code``, over
    its ``field`` (None: none) with the parameters ``a, b``; ``row`` also holds its state."""

    code = ek.EXTERNAL
    field: Field | None = None

    def __init__(self, k_max: float = K_MAX, a: float = 0.0, b: float = 0.0):
        self.row = np.array([[self.code, 0.0, float(k_max), a, b, 0.0]])
        super().__init__(k_max)

    def reset(self) -> None:
        self.row[0, ek._STATE] = 0.0

    def _data(self) -> np.ndarray | None:
        return None if self.field is None else self.field.packed

    def packed(self):
        return None if self.field is not None and self.field.packed is None else (self.row[0], self._data())

    def terms(self, s: TickState):
        data = self._data()
        v = math.nan if self.field is None else self.field.value(s.fx, s.fy)
        r = ek.terms(self.row, 0, float(v), s.array(), np.zeros(1) if data is None else data)
        return r[1:] if r[0] else None


class Idle(_Compiled):
    """Centring when the screen is not touched (eq. 5): K = K_max I3, reference X0."""

    name = "idle"
    code = ek.IDLE


class Stiffness(_Compiled):
    """Elastic normal force (eq. 1): K = diag(K_max, K_max, k_mat), lateral axes locked.

    k_mat : N/m, the simulated stiffness (a number or a stiffness map field).
    """

    name = "stiffness"
    code = ek.STIFFNESS

    def __init__(self, k_mat, k_max: float = K_MAX):
        self.k_mat = self.field = _field(k_mat)
        super().__init__(k_max)


class Shape(_Compiled):
    """Follow the height h(f) under the finger (eq. 2): K = K_max I3, reference X0 + h e_z.

    height : field of heights in m (a height map or a mesh top surface,
             :class:`surfhap.ff.fields.MeshHeightField`); ``scale`` multiplies it.
    """

    name = "shape"
    code = ek.SHAPE

    def __init__(self, height: Field, scale: float = 1.0, k_max: float = K_MAX):
        self.height = self.field = _field(height)
        self.scale = float(scale)
        super().__init__(k_max, self.scale)


class Roughness(_Compiled):
    """Grating vibration (eq. 3): normal displacement ``delta sin(phi)``, K = K_max I3.

    depth  : m, grating depth delta (number or roughness map; NaN / 0 = smooth).
    period : m, spatial period lambda.

    Eq. 3 (and eq. 8) print the phase as ``2 pi lambda |f_dot|``: a phase proportional to the
    *speed* would not oscillate during a steady stroke. What a grating of period lambda
    gives is a phase that advances with the *distance travelled*,
    ``phi = 2 pi / lambda * integral |f_dot| dt``, i.e. a vibration at ``|f_dot| / lambda``
    Hz; that is what is computed here. The paper also adds ``delta sin`` as a force; with
    delta named a *depth* (m) it is applied as an offset of the normal reference, so the
    position-controlled screen traces a grating of that depth (force amplitude K_max delta).
    """

    name = "roughness"
    vibration = True  # its offset bypasses the control law's reference rate limit
    code = ek.ROUGHNESS

    def __init__(self, depth, period: float, k_max: float = K_MAX):
        if not (math.isfinite(period) and period > 0):
            raise ValueError("roughness period must be > 0 m")
        self.depth = self.field = _field(depth)
        self.period = float(period)
        super().__init__(k_max, self.period)

    phase = property(lambda self: float(self.row[0, ek._STATE]), doc="rad, the grating's phase in [0, 2 pi)")


class Sliding(_Compiled):
    """Follow (alpha > 0) / Reverse (alpha < 0) lateral screen motion (eq. 4), normal axis held.

    alpha : slipperiness in [-1, 1] (number or friction map).
    nu    : N s/m, damping coefficient (default: the Falcon's largest, 20 N s/m, CHAI3D).

    K = diag(0, 0, K_max) (Table 2). Eq. 4 writes ``alpha f_dot - nu f_dot ^ e_z``; read
    literally its second term is a force across the stroke proportional to the finger's
    speed, which damps nothing, and ``alpha`` in [-1, 1] times a velocity is not a force.
    What the text describes is a moving force along the finger's velocity and damping of
    the screen's motion. Implemented: ``F_xy = nu (alpha f_dot - v_screen)``: damping nu of
    the screen's in-plane velocity (binormal, as the paper says, and tangential, which the
    paper leaves to the device's own friction) and a moving force ``alpha nu f_dot``, so the
    screen settles at ``alpha`` times the finger's world velocity: relative sliding
    ``(1 - alpha) f_dot`` (Follow: ~0, Reverse: doubled). ``f_dot`` is the finger's velocity
    in the world frame (touch velocity on the screen plus the screen's velocity).

    mass : kg, moving mass; adds ``alpha * mass * f_ddot`` so that the screen's inertia does
           not make it lag the finger (the inertial counterpart of the paper's weight
           compensation, Sec. 4.2 "Transparency"; 0 = off). Without it the screen lags by
           ``omega m / nu`` (6 % at 0.5 Hz for the tablet).
    """

    name = "sliding"
    code = ek.SLIDING

    def __init__(self, alpha, nu: float = 20.0, mass: float = 0.0, k_max: float = K_MAX):
        if not (math.isfinite(nu) and nu >= 0):
            raise ValueError("sliding damping nu must be >= 0")
        if not (math.isfinite(mass) and 0.0 <= mass <= 20.0):
            raise ValueError("sliding mass must be within 0-20 kg")
        self.mass = float(mass)
        self.alpha = self.field = _field(alpha)
        self.nu = float(nu)
        super().__init__(k_max, self.nu, self.mass)


class Attraction(_Compiled):
    """Lateral pull towards (strength > 0) or push away from (< 0) points of interest.

    The map use case of 004 (Sec. 6) attracts or repels the finger at points of interest
    but gives no law. CHOICE: a force towards each point within its radius, growing
    linearly from 0 at the radius to ``strength`` (N) at half the radius and held there;
    it is a feed-forward term only (the screen, held laterally by K_max, shifts by
    F / K_max and drags the finger through friction; with Sliding active it moves freely).

    points : sequence of ``(x, y, radius, strength)`` in m, m, m, N.
    """

    name = "attraction"
    code = ek.ATTRACTION

    def __init__(self, points, k_max: float = K_MAX):
        self.points = [(float(x), float(y), float(r), float(f)) for x, y, r, f in points]
        for _, _, r, _ in self.points:
            if not r > 0:
                raise ValueError("attraction radius must be > 0 m")
        self._points = np.array(self.points, dtype=float).reshape(-1)
        super().__init__(k_max, len(self.points))

    def _data(self) -> np.ndarray:
        return self._points
