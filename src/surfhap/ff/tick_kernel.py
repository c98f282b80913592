"""The compiled per-tick arithmetic of the force loop (numba kernels over small arrays, as
:mod:`surfhap.render.drive_kernel` does for the texture laws), semantics in
:mod:`surfhap.ff.engine` (the one implementation of the force law and its limits): :func:`observe` takes the device
position (clock, stamp, plausibility, velocity filter); :func:`finish` is the control law's tail
after the effects' merged terms (bumpless reference, damping, eq. 8) followed by
:func:`limit`, the safety stage's output (workspace brake and wall, stop landing, clamp, slew)
-- the safety limits applied last, in one call per tick.

Layouts (float64 arrays, indices below):

* ``S`` safety state: p (0:3) m, v (3:6) m/s, prev (6:9) N, then the own clock and stamps;
* ``P`` safety parameters, from :class:`surfhap.ff.params.DeviceParams` (:func:`safety_params`);
* ``N`` int64 counters (:data:`COUNTERS` order);
* ``R`` control-law reference: rx, ry, rz (m), fresh (1 = take the screen's position);
* ``L`` control-law parameters: k_max, damping, weight, h_lim, ref_step;
* ``T`` tick state: :class:`surfhap.ff.effects.TickState`'s fields (0:17), then the touch
  bookkeeping of :class:`surfhap.ff.engine.FFEngine` (indices below), ``H`` (2, n) the ring of
  screen x, y per tick; ``E``, ``F``, ``X`` the effects (:mod:`surfhap.ff.effect_kernel`).

:func:`tick` is one haptic tick in one call: :func:`kinematics` (:func:`observe`, touch
freshness, prediction, history) and :func:`finish` (the effects merged by
:func:`surfhap.ff.effect_kernel.merge`, the control law, :func:`limit`); with effects evaluated
in Python the engine calls :func:`kinematics` and :func:`finish` around them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from surfhap.ff import effect_kernel as ek
from surfhap.ff.effect_kernel import _DT, _FAX, _FAY, _FVX, _FVY, _FX, _FY, _PX, _PY, _SPEED, _T, _TOUCHED

__all__ = ["observe", "limit", "law", "kinematics", "finish", "tick", "views", "buffers", "new_tick_state", "safety_params", "new_state", "warm_up", "COUNTERS", "MAX_STEP"]

MAX_STEP = 1.0  # s, largest clock advance per tick (a stall beyond this is past every timeout anyway)
_EPS = 1e-9  # s, rounding of the watchdog comparison

# S: state
_P, _V, _PREV = 0, 3, 6
_NOW, _RAW, _STAMP, _POS_AT, _P_AT, _ZERO, _STOP_AT = 9, 10, 11, 12, 13, 14, 15
_S_SIZE = 16
# P: parameters
_FMAX, _WS, _BOUND, _GRAV = 0, 3, 6, 9
(_PERIOD, _STEP, _WALL_K, _TIMEOUT, _TAU, _MAX_SPEED, _LAND_TIME, _LAND_DAMP, _WALL_DAMP, _DECEL, _BRAKE_GAIN,
 _MARGIN, _MASS, _SLEW) = range(12, 26)
_P_SIZE = 26
# N: counters
COUNTERS = ("ticks", "clamped", "slew_limited", "faults", "device_lost", "workspace", "stopped", "stale", "rejected",
            "braked")
_TICKS, _CLAMPED, _SLEWED, _FAULTS, _LOST, _WS_N, _STOPPED, _STALE, _REJECTED, _BRAKED = range(10)
# T after the TickState fields: the last accepted touch's caller stamp, a touch since the last
# tick, its arrival on the safety clock, the predictor's last update, finger down, last finite
# caller time, ticks recorded in H, mask, stale touches, touch_timeout, max_extrapolate, the
# predictor's output (x, y, vx, vy, started) and "reset the predictor before its next update"
(_STAMP_T, _NEW, _TOUCH_AT, _T_PRED, _FINGER, _T_LAST, _HK, _MASK, _STALE_T, _TTIMEOUT, _MAX_EX, _QX, _QY, _QVX, _QVY,
 _QON, _QRESET) = range(17, 34)
_T_SIZE = 34
HIST = 512  # ticks of screen positions kept (0.5 s at 1 kHz)
_ZR, _ZO, _ZT = _S_SIZE, _S_SIZE + 4, _S_SIZE + 7  # Z: S, R, out, T, H
_ZH = _ZT + _T_SIZE


def safety_params(device, rate: float, velocity_cutoff: float) -> np.ndarray:
    """The ``P`` array of ``device`` (a DeviceParams) at ``rate`` Hz (in the order of the indices above)."""
    d = device
    p = np.array([*d.f_max, *d.workspace, *d.position_bound, 0.0, 0.0, d.weight,  # weight: N per axis
                  1.0 / rate, d.slew / rate, d.wall_k, d.device_timeout, 1.0 / (2.0 * math.pi * velocity_cutoff),
                  d.max_speed, d.land_time, d.land_damping, d.wall_damping, d.brake_decel, d.brake_gain,
                  d.brake_margin, d.moving_mass if d.moving_mass > 0.0 else 1.0, d.slew], dtype=float)
    assert p.shape == (_P_SIZE,)
    return p


def new_state() -> np.ndarray:
    """A reset ``S``: at rest at X0, clock 0, no stamp yet, no stop."""
    s = np.zeros(_S_SIZE)
    s[_RAW] = math.nan  # last finite caller time
    s[_STAMP] = s[_POS_AT] = s[_P_AT] = -math.inf
    s[_ZERO] = 1.0
    s[_STOP_AT] = math.inf
    return s


def new_tick_state(dt: float, touch_timeout: float, max_extrapolate: float) -> np.ndarray:
    """A reset ``T``: untouched, at rest at X0, no touch yet."""
    T = np.zeros(_T_SIZE)
    T[_DT], T[_TTIMEOUT], T[_MAX_EX] = dt, touch_timeout, max_extrapolate
    T[_STAMP_T] = T[_TOUCH_AT] = -math.inf
    return T


@numba.njit(cache=True, inline="always")
def _finite(x):
    return x == x and abs(x) != math.inf


@numba.njit(cache=True)
def observe(S, P, N, t, t_pos, px, py, pz):
    """Advance the own clock one tick and take the device position if plausible; True when
    accepted (p, v updated). ``t_pos`` has passed the arrival law upstream: a non-finite one
    (STALE) or one older than the last is stale; a later one than ``t`` counts as arriving now."""
    N[_TICKS] += 1
    period = P[_PERIOD]
    raw = S[_RAW]
    dt = t - raw if (_finite(t) and raw == raw) else period
    if not dt >= period:  # stopped, backwards or first tick
        dt = period
    elif dt > MAX_STEP:
        dt = MAX_STEP
    if _finite(t):
        S[_RAW] = t
    else:
        N[_FAULTS] += 1
    c = S[_NOW] + dt
    S[_NOW] = c
    S[_ZERO] = 1.0
    if not (_finite(t_pos) and t == t and t_pos >= S[_STAMP]):
        N[_STALE] += 1
        return False
    if not (abs(px) <= P[_BOUND] and abs(py) <= P[_BOUND + 1] and abs(pz) <= P[_BOUND + 2]):  # also NaN
        N[_FAULTS] += 1
        return False
    h = c - S[_P_AT]
    if h <= P[_TIMEOUT]:
        d = max(abs(px - S[_P]), abs(py - S[_P + 1]), abs(pz - S[_P + 2]))
        if d > P[_MAX_SPEED] * h:
            N[_REJECTED] += 1
            return False
        g = h / (P[_TAU] + h)
        S[_V] += g * ((px - S[_P]) / h - S[_V])
        S[_V + 1] += g * ((py - S[_P + 1]) / h - S[_V + 1])
        S[_V + 2] += g * ((pz - S[_P + 2]) / h - S[_V + 2])
    else:  # first position, or after a gap: no difference to take
        S[_V] = S[_V + 1] = S[_V + 2] = 0.0
    S[_P], S[_P + 1], S[_P + 2] = px, py, pz
    S[_P_AT] = c
    if t_pos > S[_STAMP]:
        S[_STAMP] = t_pos
        age = t - t_pos
        S[_POS_AT] = c - (age if age > 0.0 else 0.0)
    if c - S[_POS_AT] <= P[_TIMEOUT] + _EPS:
        S[_ZERO] = 0.0
    else:
        N[_LOST] += 1
    return True


@numba.njit(cache=True, inline="always")
def _wall(S, P, N, i, f):
    """Brake towards the wall of axis i, and the damped wall beyond it."""
    p, v, w = S[_P + i], S[_V + i], P[_WS + i]
    if p > w:
        N[_WS_N] += 1
        return min(f, 0.0) - P[_WALL_K] * (p - w) - P[_WALL_DAMP] * v
    if p < -w:
        N[_WS_N] += 1
        return max(f, 0.0) + P[_WALL_K] * (-w - p) - P[_WALL_DAMP] * v
    s = 1.0 if v > 0.0 else -1.0
    a, slew, m, grav = P[_DECEL], P[_SLEW], P[_MASS], P[_GRAV + i]
    # the output turns at the slew rate: project the motion over the time the net force needs
    # to go from its present value (along the motion) to braking at m a
    f_net = s * (S[_PREV + i] - grav)
    turn = (f_net + m * a) / slew if f_net + m * a > 0.0 else 0.0
    dv = (f_net * turn - 0.5 * slew * turn * turn) / m
    d = w - s * p - P[_MARGIN] - (s * v * turn + 0.5 * dv * turn)  # distance left once braking
    v_lim = math.sqrt(2.0 * a * d) if d > 0.0 else 0.0
    excess = s * v + (dv if dv > 0.0 else 0.0) - v_lim
    if excess > 0.0:
        # along the motion at most: brake B x excess (the weight compensation counted on z)
        cap = s * grav - P[_BRAKE_GAIN] * excess
        if s * f > cap:
            N[_BRAKED] += 1
            return s * cap
    return f


@numba.njit(cache=True)
def limit(S, P, N, f0, f1, f2, stop, out):
    """The safe force (into ``out`` (3,) N) for the requested one, given this tick's :func:`observe`."""
    zero = S[_ZERO] != 0.0
    if not (_finite(f0) and _finite(f1) and _finite(f2)):
        N[_FAULTS] += 1
        zero = True
    now = S[_NOW]
    if stop:
        N[_STOPPED] += 1
        if S[_STOP_AT] == math.inf:
            S[_STOP_AT] = now
    if zero:
        f0 = f1 = f2 = 0.0
    elif stop:
        f0 = f1 = 0.0
        land = P[_LAND_TIME]
        left = 1.0 - (now - S[_STOP_AT]) / land if land > 0 else 0.0
        f2 = P[_GRAV + 2] * left - P[_LAND_DAMP] * S[_V + 2] if left > 0.0 else 0.0
    else:
        f0 = _wall(S, P, N, 0, f0)
        f1 = _wall(S, P, N, 1, f1)
        f2 = _wall(S, P, N, 2, f2)
    step = P[_STEP]
    clamped = slewed = False
    for i in range(3):  # clamp to +-f_max, then limit the change
        f = f0 if i == 0 else (f1 if i == 1 else f2)
        m = P[_FMAX + i]
        if f > m:
            f = m
            clamped = True
        elif f < -m:
            f = -m
            clamped = True
        prev = S[_PREV + i]
        if f > prev + step:
            f = prev + step
            slewed = True
        elif f < prev - step:
            f = prev - step
            slewed = True
        S[_PREV + i] = f
        out[i] = f
    if clamped:
        N[_CLAMPED] += 1
    if slewed:
        N[_SLEWED] += 1


@numba.njit(cache=True, inline="always")
def _damping(k, km, d):
    return d if k == km else (0.0 if k <= 0.0 else d * math.sqrt(k / km))


@numba.njit(cache=True)
def law(R, L, px, py, pz, vx, vy, vz, kx, ky, kz, h, hv, fx, fy, fz, out):
    """Eq. 8 of the merged terms at screen position p, velocity v (into ``out`` (3,) N): the
    bumpless reference (free axes track the screen, held ones approach the target at ref_step
    per tick) and the damping on held axes."""
    km, d, weight, lim, st = L[0], L[1], L[2], L[3], L[4]
    if h > lim:
        h = lim
    elif h < -lim:
        h = -lim
    if R[3] != 0.0:
        R[0], R[1], R[2] = px, py, pz
        R[3] = 0.0
    rx = px if kx <= 0.0 else R[0] + max(-st, min(st, -R[0]))
    ry = py if ky <= 0.0 else R[1] + max(-st, min(st, -R[1]))
    rz = pz if kz <= 0.0 else R[2] + max(-st, min(st, h - R[2]))
    R[0], R[1], R[2] = rx, ry, rz
    out[0] = fx + kx * (rx - px) - _damping(kx, km, d) * vx
    out[1] = fy + ky * (ry - py) - _damping(ky, km, d) * vy
    out[2] = weight + fz + kz * (rz + hv - pz) - _damping(kz, km, d) * vz


@numba.njit(cache=True)
def kinematics(S, P, N, T, H, t, t_pos, px, py, pz):
    """:func:`observe`, then the screen's history, the touch's freshness on the safety clock
    (a touch stamp older than this tick by more than one period is stale) and the finger's
    world position, extrapolated from the predictor's last update by at most ``max_extrapolate``."""
    if observe(S, P, N, t, t_pos, px, py, pz):
        for i in range(6):
            T[_PX + i] = S[_P + i]
    c = S[_NOW]
    T[_T] = c
    k = int(T[_HK])
    j = k % H.shape[1]
    H[0, j], H[1, j] = T[_PX], T[_PY]
    T[_HK] = k + 1
    finite_t = _finite(t)
    if finite_t:
        T[_T_LAST] = t
    if T[_NEW] != 0.0:  # stamp its arrival on this clock: the caller's stamp can only age it
        T[_NEW] = 0.0
        age = t - T[_STAMP_T]
        if not (finite_t and age >= -T[_DT]):
            T[_STALE_T] += 1.0
            T[_FINGER] = T[_QON] = 0.0
            T[_QRESET] = 1.0
            T[_TOUCH_AT] = -math.inf
            if finite_t:
                T[_STAMP_T] = t
        else:
            T[_TOUCH_AT] = c - (age if age > 0.0 else 0.0)
    touched = T[_FINGER] != 0.0 and (c - T[_TOUCH_AT]) <= T[_TTIMEOUT] + 1e-9 and T[_QON] != 0.0
    if touched:
        ahead = t - T[_T_PRED]
        if not ahead > 0.0:
            ahead = 0.0
        elif ahead > T[_MAX_EX]:
            ahead = T[_MAX_EX]
        T[_FX] = T[_QX] + T[_QVX] * ahead
        T[_FY] = T[_QY] + T[_QVY] * ahead
        T[_FVX], T[_FVY] = T[_QVX], T[_QVY]
        T[_SPEED] = math.hypot(T[_FVX], T[_FVY])
    else:
        T[_FVX] = T[_FVY] = T[_SPEED] = 0.0
    T[_TOUCHED] = 1.0 if touched else 0.0


@numba.njit(cache=True)
def finish(S, P, N, R, L, T, E, F, X, stop, out):
    """One tick's force after :func:`kinematics` (into ``out`` (3,) N): the effects merged at this
    tick's state, the control law at the accepted position, then the safety stage's :func:`limit` (last)."""
    mask, kx, ky, kz, h, hv, fx, fy, fz = ek.merge(E, F, X, T, L[0])
    T[_MASK] = mask
    law(R, L, S[_P], S[_P + 1], S[_P + 2], S[_V], S[_V + 1], S[_V + 2], kx, ky, kz, h, hv, fx, fy, fz, out)
    limit(S, P, N, out[0], out[1], out[2], stop, out)


@numba.njit(cache=True, inline="always")
def views(Z, PL, EX):
    """The engine's arrays as views of its three buffers (few arguments: each array passed to a
    compiled call costs its unboxing): ``S, R, out, T, H`` of ``Z``, ``P, L`` of ``PL``, ``E, X`` of ``EX``."""
    return (Z[:_ZR], Z[_ZR:_ZO], Z[_ZO:_ZT], Z[_ZT:_ZH], Z[_ZH:].reshape((2, HIST)), PL[:_P_SIZE], PL[_P_SIZE:],
            EX[:, :ek.E_COLS], EX[:, ek.E_COLS:])


@numba.njit(cache=True)
def tick(Z, PL, N, EX, F, t, t_pos, px, py, pz, stop):
    """One haptic tick of compiled effects (:func:`kinematics`, :func:`finish`) on the engine's
    buffers (:func:`views`); the force is in ``out``."""
    S, R, out, T, H, P, L, E, X = views(Z, PL, EX)
    kinematics(S, P, N, T, H, t, t_pos, px, py, pz)
    finish(S, P, N, R, L, T, E, F, X, stop, out)


def buffers(P: np.ndarray, L: np.ndarray):
    """The buffers ``Z`` (zeros: the caller resets ``S``, ``R`` and ``T`` in it) and ``PL`` holding
    the safety parameters ``P`` and the control law's ``L`` (:func:`views`)."""
    return np.zeros(_ZH + 2 * HIST), np.concatenate([P, L])


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel now, on scratch arrays, so that no
    real-time tick pays for it (call before starting a haptic thread)."""
    from surfhap.ff.params import DeviceParams

    N, EX = np.zeros(len(COUNTERS), dtype=np.int64), np.zeros((1, ek.E_COLS + ek.X_COLS))
    Z, PL = buffers(safety_params(DeviceParams(), 1000.0, 100.0), np.array([1000.0, 10.0, 3.8, 0.04, 2e-4]))
    S, R, out, T, H, P, L, E, X = views.py_func(Z, PL, EX)
    S[:], T[:] = new_state(), new_tick_state(1e-3, 0.1, 0.05)
    tick(Z, PL, N, EX, np.zeros(1), 0.0, 0.0, 0.0, 0.0, 0.0, False)
    kinematics(S, P, N, T, H, 0.0, 0.0, 0.0, 0.0, 0.0)
    finish(S, P, N, R, L, T, E, np.zeros(1), X, False, out)
    observe(S, P, N, 0.0, 0.0, 0.0, 0.0, 0.0)
    limit(S, P, N, 0.0, 0.0, 0.0, True, out)
    law(R, L, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1000.0, 1000.0, 1000.0, 0.0, 0.0, 0.0, 0.0, 0.0, out)
    ek.value(np.array([ek.CONST, 0.0]), 0, 0.0, 0.0)
