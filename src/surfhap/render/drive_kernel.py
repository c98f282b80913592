"""The compiled parts of the drive laws (:class:`surfhap.render.drive.DriveLaw`), kept apart so
that listing materials and methods does not import numba.

Each drive law's equation is written here once, as the one vectorised evaluation its law object
(:mod:`surfhap.render.drive`) runs for rendering, gain planning, the expected spectrum and
``compare``: ``friction_texture_law`` is the whole of the Otake laws and friction-only (003 eq. 6,
001 eq. 5), ``zhao_law`` Zhao's (000 eq. 3-4), ``square_law`` the square baseline (000 Sec. 3);
``target_to_voltage`` is the tail they share (``V = alpha sqrt(max(F, 0))``).
Compiled, one pass each: the live engine runs a few samples per block, where numpy's
per-operation overhead costs more than the arithmetic; njit functions take arrays of any length.
"""

from __future__ import annotations

import math

import numba

from surfhap.models.friction_kernel import quasi_static_cof

__all__ = ["target_to_voltage", "friction_texture_law", "zhao_law", "square_law", "law_block", "LAW_FRICTION_TEXTURE", "LAW_ZHAO",
           "TEXTURE_NONE", "TEXTURE_RELATIVE", "TEXTURE_COF", "TEXTURE_ACCELERATION"]

# how a texture sample x becomes the textural CoF mu_t (``scale`` = texture_gain times ...)
TEXTURE_NONE = 0  # mu_t = 0
TEXTURE_RELATIVE = 1  # mu_t = scale mu_low x           (scale = gain * texture_relative_scale)
TEXTURE_COF = 2  # mu_t = scale x                       (scale = gain)
TEXTURE_ACCELERATION = 3  # mu_t = scale x / fn, 0 without contact (scale = gain * effective_mass)
# the laws :func:`law_block` runs, by kind, with their scalar parameters packed in one float array
LAW_FRICTION_TEXTURE = 0  # friction_texture_law: quasi (0/1), a, b, c, d, q, mu0, texture_mode, scale, beta, alpha
LAW_ZHAO = 1  # zhao_law: mu0, constant_load, texture_mode, scale, alpha


@numba.njit(cache=True, nogil=True)
def target_to_voltage(target, load, alpha, voltage):
    """The tail every law shares, in one pass: ``voltage = alpha sqrt(max(target, 0))`` (V; a
    NaN target stays NaN for the safety stage to catch). Returns (clipped, touching): samples
    in contact (load > 0) whose target is negative (not renderable), and samples in contact."""
    clipped = 0
    touching = 0
    for i in range(target.shape[0]):
        t = target[i]
        if load[i] > 0.0:
            touching += 1
            if t < 0.0:
                clipped += 1
        voltage[i] = 0.0 if t <= 0.0 else alpha * math.sqrt(t)
    return clipped, touching


@numba.njit(cache=True, nogil=True)
def friction_texture_law(load, speed, texture, quasi, a, b, c, d, q, mu0, texture_mode, scale, beta, alpha, out):
    """``F = (mu_low(fn, v) + beta mu_t) fn`` and ``V = alpha sqrt(max(F, 0))`` per sample.

    load, speed, texture: (n,) float (N, m/s, texture quantity); ``quasi`` True for eq. 3 of
    003 with (a, b, c, d, q), False for a constant ``mu0``; ``texture_mode`` one of the
    TEXTURE_* constants with its ``scale``. Writes out (4, n): voltage (V), target (N), mu_low,
    mu_tex (a :class:`~surfhap.render.drive.DriveBlock`'s rows); returns (clipped, touching) as
    :func:`target_to_voltage`.
    """
    last_fn = last_v = math.nan
    m = mu0
    for i in range(load.shape[0]):
        fn = load[i]
        v = speed[i]
        if quasi and not (fn == last_fn and v == last_v):  # the finger state is held between touch samples
            m = quasi_static_cof(fn, v, a, b, c, d, q)
            last_fn, last_v = fn, v
        x = texture[i]
        if texture_mode == TEXTURE_RELATIVE:
            t = scale * m * x
        elif texture_mode == TEXTURE_COF:
            t = scale * x
        elif texture_mode == TEXTURE_ACCELERATION:
            t = scale * x / fn if fn > 0.0 else 0.0
        else:
            t = 0.0
        out[2, i], out[3, i], out[1, i] = m, t, (m + beta * t) * fn  # F = (mu_low + beta mu_t) fn
    return target_to_voltage(out[1], load, alpha, out[0])


@numba.njit(cache=True, nogil=True)
def zhao_law(load, speed, texture, mu0, constant_load, texture_mode, scale, alpha, out):
    """Zhao et al. (000 eq. 3-4): ``F = mu0 fn_c + f_t`` with ``fn_c`` = ``constant_load`` N while
    touching (the measured load when ``constant_load`` <= 0) and ``f_t = scale x`` for an
    acceleration bank (``scale`` = gain m_eff), ``scale x fn_c`` for a CoF bank (``scale`` =
    gain), 0 for TEXTURE_NONE or without contact; ``V = alpha sqrt(max(F, 0))``.

    load, speed (unused: Zhao's law does not follow the speed), texture: (n,) float. Writes out (4, n) as :func:`friction_texture_law` (mu_low = mu0,
    mu_tex = f_t / fn_c); returns (clipped, touching) as :func:`target_to_voltage`.
    """
    for i in range(load.shape[0]):
        ld = load[i]
        fn = 0.0
        ft = 0.0
        if ld > 0.0:
            fn = constant_load if constant_load > 0.0 else ld
            if texture_mode == TEXTURE_ACCELERATION:
                ft = scale * texture[i]
            elif texture_mode == TEXTURE_COF:
                ft = scale * texture[i] * fn
        out[2, i], out[3, i], out[1, i] = mu0, ft / fn if fn > 0.0 else 0.0, mu0 * fn + ft  # F = mu0 fn_c + f_t
    return target_to_voltage(out[1], load, alpha, out[0])


@numba.njit(cache=True, nogil=True)
def square_law(start, cycles_per_sample, on_force, load, alpha, target, voltage):
    """The square baseline (000 Sec. 3): ``F = on_force`` N in the first half of each period and
    0 in the second, sample ``start + i`` at ``cycles_per_sample`` (= f_sq / rate) periods per
    sample, whatever the load and speed; ``V = alpha sqrt(F)`` (the constant V_sq). Writes
    target (n,) N and voltage (n,) V; returns (clipped, touching) as :func:`target_to_voltage`."""
    for i in range(target.shape[0]):
        target[i] = on_force if ((start + i) * cycles_per_sample) % 1.0 < 0.5 else 0.0
    return target_to_voltage(target, load, alpha, voltage)


@numba.njit(cache=True, nogil=True)
def law_block(kind, p, load, speed, texture, out):
    """The law of ``kind`` (``LAW_*``) with its parameters ``p`` (float array, in the order of
    the law's kernel) over (n,) arrays into ``out`` (4, n): one compiled entry point for the
    laws' objects and the texture chain's block; returns (clipped, touching)."""
    if kind == LAW_ZHAO:
        return zhao_law(load, speed, texture, p[0], p[1], int(p[2]), p[3], p[4], out)
    return friction_texture_law(load, speed, texture, p[0] != 0.0, p[1], p[2], p[3], p[4], p[5], p[6], int(p[7]), p[8], p[9],
                                p[10], out)
