"""The compiled parts of the drive laws (:class:`surfhap.render.drive.DriveLaw`), kept apart so
that listing materials and methods does not import numba.

``target_to_voltage`` is the tail every law shares; ``friction_texture_law`` is the whole of
the Otake laws and friction-only (003 eq. 6, 001 eq. 5) in one pass, for the live engine's
few samples per block, where numpy's per-operation overhead costs more than the arithmetic.
"""

from __future__ import annotations

import math

import numba

from surfhap.models.friction_kernel import quasi_static_cof

__all__ = ["target_to_voltage", "friction_texture_law", "TEXTURE_NONE", "TEXTURE_RELATIVE", "TEXTURE_COF", "TEXTURE_ACCELERATION"]

# how a texture sample x becomes the textural CoF mu_t (``scale`` = texture_gain times ...)
TEXTURE_NONE = 0  # mu_t = 0
TEXTURE_RELATIVE = 1  # mu_t = scale mu_low x           (scale = gain * texture_relative_scale)
TEXTURE_COF = 2  # mu_t = scale x                       (scale = gain)
TEXTURE_ACCELERATION = 3  # mu_t = scale x / fn, 0 without contact (scale = gain * effective_mass)


@numba.njit(cache=True, nogil=True, inline="always")
def _to_voltage(t, alpha):
    # V = alpha sqrt(max(F, 0)); a NaN target stays NaN for the safety stage to catch
    return 0.0 if t <= 0.0 else alpha * math.sqrt(t)


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
        voltage[i] = _to_voltage(t, alpha)
    return clipped, touching


@numba.njit(cache=True, nogil=True)
def friction_texture_law(load, speed, texture, quasi, a, b, c, d, q, mu0, texture_mode, scale, beta, alpha,
                         mu_low, mu_tex, target, voltage):
    """``F = (mu_low(fn, v) + beta mu_t) fn`` and ``V = alpha sqrt(max(F, 0))`` per sample.

    load, speed, texture: (n,) float (N, m/s, texture quantity); ``quasi`` True for eq. 3 of
    003 with (a, b, c, d, q), False for a constant ``mu0``; ``texture_mode`` one of the
    TEXTURE_* constants with its ``scale``. Writes the (n,) outputs mu_low, mu_tex, target (N)
    and voltage (V); returns (clipped, touching) as :func:`target_to_voltage`.
    """
    clipped = 0
    touching = 0
    for i in range(load.shape[0]):
        fn = load[i]
        m = quasi_static_cof(fn, speed[i], a, b, c, d, q) if quasi else mu0
        x = texture[i]
        if texture_mode == TEXTURE_RELATIVE:
            t = scale * m * x
        elif texture_mode == TEXTURE_COF:
            t = scale * x
        elif texture_mode == TEXTURE_ACCELERATION:
            t = scale * x / fn if fn > 0.0 else 0.0
        else:
            t = 0.0
        f = (m + beta * t) * fn
        mu_low[i] = m
        mu_tex[i] = t
        target[i] = f
        if fn > 0.0:
            touching += 1
            if f < 0.0:
                clipped += 1
        voltage[i] = _to_voltage(f, alpha)
    return clipped, touching
