"""The KinesTouch effects (paper 004, Sec. 3) as per-tick processors.

Every effect has ``reset()`` and ``terms(s)``: given the tick state ``s``
(:class:`TickState`) it returns None where it does not apply at the finger, else its terms
of the control law (eq. 8) as a tuple ``(kx, ky, kz, h, ffx, ffy, ffz)``:

* ``kx, ky, kz``   : N/m, the diagonal of its stabilisation matrix K (004 Table 2);
* ``h``            : m, its offset of the normal reference ``X0 + h e_z``;
* ``ffx, ffy, ffz``: N, its feed-forward force (moving force, grating, attraction).

An effect alone is its paper law (eqs. 1-5), ``ff + K (X0 + h e_z - X_t)`` (X0 = 0, N in the
device frame of :mod:`surfhap.ff.params`); :meth:`surfhap.ff.engine.FFEngine.merge` merges
several effects into one force (eq. 8). Parameters that vary over the picture come from :mod:`surfhap.ff.fields`
(a NaN value switches the effect off at that point).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

from surfhap.ff.fields import ConstantField, Field
from surfhap.ff.params import K_MAX

__all__ = ["TickState", "Effect", "Stiffness", "Shape", "Roughness", "Sliding", "Idle", "Attraction"]

TWO_PI = 2.0 * math.pi


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

    @abstractmethod
    def terms(self, s: TickState):
        """None (not here) or ``(kx, ky, kz, h, ffx, ffy, ffz)`` for this tick."""


class Idle(Effect):
    """Centring when the screen is not touched (eq. 5): K = K_max I3, reference X0."""

    name = "idle"

    def terms(self, s: TickState):
        km = self.k_max
        return (km, km, km, 0.0, 0.0, 0.0, 0.0)


class Stiffness(Effect):
    """Elastic normal force (eq. 1): K = diag(K_max, K_max, k_mat), lateral axes locked.

    k_mat : N/m, the simulated stiffness (a number or a stiffness map field).
    """

    name = "stiffness"

    def __init__(self, k_mat, k_max: float = K_MAX):
        self.k_mat = _field(k_mat)
        super().__init__(k_max)

    def terms(self, s: TickState):
        k = self.k_mat.value(s.fx, s.fy)
        if not k > 0.0:  # NaN or <= 0: no material here
            return None
        km = self.k_max
        return (km, km, k if k < km else km, 0.0, 0.0, 0.0, 0.0)


class Shape(Effect):
    """Follow the height h(f) under the finger (eq. 2): K = K_max I3, reference X0 + h e_z.

    height : field of heights in m (a height map or a mesh top surface,
             :class:`surfhap.ff.fields.MeshHeightField`); ``scale`` multiplies it.
    """

    name = "shape"

    def __init__(self, height: Field, scale: float = 1.0, k_max: float = K_MAX):
        self.height = _field(height)
        self.scale = float(scale)
        super().__init__(k_max)

    def terms(self, s: TickState):
        h = self.height.value(s.fx, s.fy)
        if h != h:
            return None
        km = self.k_max
        return (km, km, km, self.scale * h, 0.0, 0.0, 0.0)


class Roughness(Effect):
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

    def __init__(self, depth, period: float, k_max: float = K_MAX):
        if not (math.isfinite(period) and period > 0):
            raise ValueError("roughness period must be > 0 m")
        self.depth = _field(depth)
        self.period = float(period)
        super().__init__(k_max)

    def reset(self) -> None:
        self.phase = 0.0  # rad

    def terms(self, s: TickState):
        d = self.depth.value(s.fx, s.fy)
        if not d > 0.0:
            return None
        # the distance travelled this tick in periods, wrapped: the phase stays in [0, 2 pi)
        # whatever the speed (a non-finite or absurd speed advances it by nothing)
        cyc = s.speed * s.dt / self.period
        cyc = cyc - math.floor(cyc) if 0.0 <= cyc < 1e15 else 0.0
        ph = self.phase + TWO_PI * cyc
        if not 0.0 <= ph < TWO_PI:
            ph = ph - TWO_PI if TWO_PI <= ph < 2.0 * TWO_PI else 0.0
        self.phase = ph
        km = self.k_max
        return (km, km, km, d * math.sin(ph), 0.0, 0.0, 0.0)


class Sliding(Effect):
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

    def __init__(self, alpha, nu: float = 20.0, mass: float = 0.0, k_max: float = K_MAX):
        if not (math.isfinite(nu) and nu >= 0):
            raise ValueError("sliding damping nu must be >= 0")
        if not (math.isfinite(mass) and 0.0 <= mass <= 20.0):
            raise ValueError("sliding mass must be within 0-20 kg")
        self.mass = float(mass)
        self.alpha = _field(alpha)
        self.nu = float(nu)
        super().__init__(k_max)

    def terms(self, s: TickState):
        a = self.alpha.value(s.fx, s.fy)
        if a != a:
            return None
        a = -1.0 if a < -1.0 else (1.0 if a > 1.0 else a)
        nu = self.nu
        am = a * self.mass
        return (0.0, 0.0, self.k_max, 0.0, nu * (a * s.fvx - s.vx) + am * s.fax, nu * (a * s.fvy - s.vy) + am * s.fay,
                0.0)


class Attraction(Effect):
    """Lateral pull towards (strength > 0) or push away from (< 0) points of interest.

    The map use case of 004 (Sec. 6) attracts or repels the finger at points of interest
    but gives no law. CHOICE: a force towards each point within its radius, growing
    linearly from 0 at the radius to ``strength`` (N) at half the radius and held there;
    it is a feed-forward term only (the screen, held laterally by K_max, shifts by
    F / K_max and drags the finger through friction; with Sliding active it moves freely).

    points : sequence of ``(x, y, radius, strength)`` in m, m, m, N.
    """

    name = "attraction"

    def __init__(self, points, k_max: float = K_MAX):
        self.points = [(float(x), float(y), float(r), float(f)) for x, y, r, f in points]
        for _, _, r, _ in self.points:
            if not r > 0:
                raise ValueError("attraction radius must be > 0 m")
        super().__init__(k_max)

    def terms(self, s: TickState):
        fx = fy = 0.0
        hit = False
        px, py = s.fx, s.fy
        for x, y, r, f in self.points:
            dx = x - px
            dy = y - py
            d = math.hypot(dx, dy)
            if d >= r or d <= 0.0:
                continue
            w = 2.0 * (r - d) / r
            g = (f if w >= 1.0 else f * w) / d
            fx += g * dx
            fy += g * dy
            hit = True
        if not hit:
            return None
        km = self.k_max
        return (km, km, km, 0.0, fx, fy, 0.0)
