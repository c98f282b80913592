"""The compiled laws of the built-in effects and of their fields (the one place each lives),
called per tick by :mod:`surfhap.ff.tick_kernel` and, one effect or one point at a time, by
:meth:`surfhap.ff.effects.Effect.terms` and :meth:`surfhap.ff.fields.Field.value`.

Layouts (float64 arrays):

* a packed field (``F`` from offset ``o``): ``CONST, v``; ``GRID, x0, y0, sx, sy, nx, ny, outside,
  data (ny * nx, row-major)``; ``RECTS, n, default, then n x (x0, y0, x1, y1, mode, a, b, lo, span)``
  (mode 0: the value ``a``; 1 / 2: a ramp from ``a`` at ``lo`` to ``b`` at ``lo + span`` along x / y);
* ``E`` (n, E_COLS) effects: code, field offset in ``F`` (-1: none; Attraction: its points
  ``x, y, r, f`` from there), k_max, two parameters, state (Roughness: the phase);
* ``X`` (n, X_COLS) terms of the Python effects (code EXTERNAL): on, kx, ky, kz, h, ffx, ffy, ffz, vibration;
* ``T`` tick state: :class:`surfhap.ff.effects.TickState`'s fields in its slot order (0:17),
  then the engine's own bookkeeping (:mod:`surfhap.ff.tick_kernel`).
"""

from __future__ import annotations

import math

import numba

__all__ = ["value", "terms", "merge", "CONST", "GRID", "RECTS"]

CONST, GRID, RECTS = 0.0, 1.0, 2.0
EXTERNAL, IDLE, STIFFNESS, SHAPE, ROUGHNESS, SLIDING, ATTRACTION = range(7)
_CODE, _FIELD, _KMAX, _A, _B, _STATE = range(6)
E_COLS, X_COLS = 6, 9
_T, _DT, _TOUCHED, _FX, _FY, _FVX, _FVY, _FAX, _FAY, _SPEED, _LOAD, _PX, _PY, _PZ, _VX, _VY, _VZ = range(17)
TWO_PI = 2.0 * math.pi
_OFF = (False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@numba.njit(cache=True)
def value(F, o, x, y):
    """The packed field at ``F[o:]`` at (x, y) m (NaN: undefined there)."""
    kind = F[o]
    if kind == CONST:
        return F[o + 1]
    if kind == GRID:  # bilinear between pixel centres, ``outside`` beyond the rectangle
        nx, ny = int(F[o + 5]), int(F[o + 6])
        u = (x - F[o + 1]) * F[o + 3] - 0.5
        v = (y - F[o + 2]) * F[o + 4] - 0.5
        if not (-0.5 <= u <= nx - 0.5 and -0.5 <= v <= ny - 0.5):
            return F[o + 7]
        nx1, ny1 = nx - 1, ny - 1
        u = min(max(u, 0.0), float(nx1))
        v = min(max(v, 0.0), float(ny1))
        i, j = int(u), int(v)
        fu, fv = u - i, v - j
        i1 = i + 1 if i < nx1 else i
        r0 = o + 8 + j * nx
        r1 = o + 8 + (j + 1 if j < ny1 else j) * nx
        top = F[r0 + i] + fu * (F[r0 + i1] - F[r0 + i])
        bot = F[r1 + i] + fu * (F[r1 + i1] - F[r1 + i])
        return top + fv * (bot - top)
    for k in range(int(F[o + 1]) - 1, -1, -1):  # RECTS: the last one containing the point
        r = o + 3 + 9 * k
        if F[r] <= x <= F[r + 2] and F[r + 1] <= y <= F[r + 3]:
            mode = F[r + 4]
            if mode == 0.0:
                return F[r + 5]
            return F[r + 5] + (F[r + 6] - F[r + 5]) * ((x if mode == 1.0 else y) - F[r + 7]) / F[r + 8]
    return F[o + 2]


@numba.njit(cache=True)
def terms(E, i, v, T, F):
    """Effect ``i``'s terms of eq. 8 given its field's value ``v`` here: ``(on, kx, ky, kz, h,
    ffx, ffy, ffz)`` (004 Sec. 3; the laws and their readings in :mod:`surfhap.ff.effects`)."""
    code, km = E[i, _CODE], E[i, _KMAX]
    if code == IDLE:  # eq. 5
        return True, km, km, km, 0.0, 0.0, 0.0, 0.0
    if code == STIFFNESS:  # eq. 1
        if not v > 0.0:  # NaN or <= 0: no material here
            return _OFF
        return True, km, km, v if v < km else km, 0.0, 0.0, 0.0, 0.0
    if code == SHAPE:  # eq. 2
        if v != v:
            return _OFF
        return True, km, km, km, E[i, _A] * v, 0.0, 0.0, 0.0
    if code == ROUGHNESS:  # eq. 3, phase from the distance travelled
        if not v > 0.0:
            return _OFF
        # the distance travelled this tick in periods, wrapped: the phase stays in [0, 2 pi)
        # whatever the speed (a non-finite or absurd speed advances it by nothing)
        cyc = T[_SPEED] * T[_DT] / E[i, _A]
        cyc = cyc - math.floor(cyc) if 0.0 <= cyc < 1e15 else 0.0
        ph = E[i, _STATE] + TWO_PI * cyc
        if not 0.0 <= ph < TWO_PI:
            ph = ph - TWO_PI if TWO_PI <= ph < 2.0 * TWO_PI else 0.0
        E[i, _STATE] = ph
        return True, km, km, km, v * math.sin(ph), 0.0, 0.0, 0.0
    if code == SLIDING:  # eq. 4 as read: nu (alpha f_dot - v_screen) + alpha m f_ddot
        if v != v:
            return _OFF
        a = -1.0 if v < -1.0 else (1.0 if v > 1.0 else v)
        nu = E[i, _A]
        am = a * E[i, _B]
        return (True, 0.0, 0.0, km, 0.0, nu * (a * T[_FVX] - T[_VX]) + am * T[_FAX],
                nu * (a * T[_FVY] - T[_VY]) + am * T[_FAY], 0.0)
    # ATTRACTION: towards each point within its radius, 0 at the radius to f at half of it
    fx = fy = 0.0
    hit = False
    o = int(E[i, _FIELD])
    for k in range(int(E[i, _A])):
        x, y, r, f = F[o + 4 * k], F[o + 4 * k + 1], F[o + 4 * k + 2], F[o + 4 * k + 3]
        dx = x - T[_FX]
        dy = y - T[_FY]
        d = math.hypot(dx, dy)
        if d >= r or d <= 0.0:
            continue
        w = 2.0 * (r - d) / r
        g = (f if w >= 1.0 else f * w) / d
        fx += g * dx
        fy += g * dy
        hit = True
    if not hit:
        return _OFF
    return True, km, km, km, 0.0, fx, fy, 0.0


@numba.njit(cache=True)
def merge(E, F, X, T, km):
    """The active effects' terms merged (eq. 8): ``(mask, kx, ky, kz, h, hv, fx, fy, fz)`` -- per
    axis the most compliant stiffness, the summed offsets (``hv`` the vibrations', which bypass
    the reference's rate limit) and the summed feed-forward forces; bit i of ``mask``: effect i on."""
    kx = ky = kz = km
    h = hv = fx = fy = fz = 0.0
    mask = 0
    if T[_TOUCHED] != 0.0:
        for i in range(E.shape[0]):
            code = E[i, _CODE]
            if code == EXTERNAL:
                on, a, b, c, hh, p, q, w = (X[i, 0] != 0.0, X[i, 1], X[i, 2], X[i, 3], X[i, 4], X[i, 5], X[i, 6],
                                            X[i, 7])
                vib = X[i, 8] != 0.0
            else:
                o = int(E[i, _FIELD])
                v = value(F, o, T[_FX], T[_FY]) if (o >= 0 and code != ATTRACTION) else math.nan
                on, a, b, c, hh, p, q, w = terms(E, i, v, T, F)
                vib = code == ROUGHNESS
            if on:
                mask |= 1 << i
                kx, ky, kz = min(kx, a), min(ky, b), min(kz, c)
                if vib:
                    hv += hh
                else:
                    h += hh
                fx += p
                fy += q
                fz += w
    return mask, kx, ky, kz, h, hv, fx, fy, fz
