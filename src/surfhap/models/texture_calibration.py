"""Texture strength from a published friction:texture voltage ratio (Otake et al. 2022, Sec. IV-D).

Otake et al. 2022 (003, Sec. IV-D) give the approximate ratios of the applied voltages,
friction component : textural component, as 10:3 (leather), 10:6 (cork), 10:6 (denim) and
10:4 (wood). Their textures were textural coefficients of friction; the built-in textures of
surfhap are stick accelerations (HapMat IMU), another modality with no physical conversion to
a CoF. Their strength is therefore calibrated to these ratios.

Definition of the voltage ratio (used throughout surfhap)
---------------------------------------------------------
Under eq. 6, ``V = alpha sqrt((mu_p + beta mu_t) fn)``. The voltage of the friction component
is ``V_f = alpha sqrt(mu_p fn)``; the voltage of the textural component is the voltage that a
textural CoF of one standard deviation would need on its own, ``V_t = alpha sqrt(beta sd(mu_t) fn)``.
The ratio is

    r = V_t / V_f = sqrt(beta sd(mu_t) / mu_p)

so 10:3 is r = 0.3. Measured on a render, ``beta sd(mu_t) / mu_p`` is the standard deviation of
the high band (>= 3.5 Hz) of the added friction over the mean of its low band, because the
added friction is ``G (mu_p + beta mu_t) fn`` for a rendering gain G
(:func:`surfhap.render.fidelity.fidelity_metrics`). The paper does not define its ratio; this
reading keeps the textural CoF below the friction one (the display cannot render a negative
CoF, 003 Sec. IV-B), which the other reading (standard deviation of ``V - V_f`` over ``V_f``)
would not for 10:6.

Relative calibration
--------------------
A calibrated texture enters the Otake laws as ``mu_t = s mu_low(fn, v) x`` with ``x`` the
texture in its own unit and ``s = r^2 / (beta sd(x))``, so ``beta sd(mu_t) / mu_low = r^2`` at
every load and speed. ``sd(x)`` is the standard deviation of the model's output above the band
split (3.5 Hz): the papers' mu_t is by definition the component above the split (003 Sec. II),
and the measurement splits there too, with the same :class:`~surfhap.signal.bands.BandSplit`
(:func:`texture_band_std` weights the model's PSD by the split's power gain).
"""

from __future__ import annotations

import numpy as np

from surfhap.signal.ar import ar_psd
from surfhap.signal.bands import BandSplit

__all__ = ["texture_band_std", "relative_scale"]


def texture_band_std(coefficients, variance: float, sample_rate: float, cutoff: float = 3.5, n: int = 1 << 18) -> float:
    """Standard deviation of the AR model's output in the texture band of the band split at
    ``cutoff`` Hz (:class:`~surfhap.signal.bands.BandSplit`, the split the fidelity metrics
    measure with): the square root of the integral of the AR PSD times the split's power gain
    over 0 to fs/2, on ``n`` + 1 points (trapezoid rule). ``cutoff = 0``: no split, the
    stationary standard deviation."""
    f = np.linspace(0.0, sample_rate / 2, n + 1)
    psd = ar_psd(coefficients, variance, sample_rate, f)
    if cutoff > 0:
        psd = psd * BandSplit(cutoff=cutoff).high_gain(f, sample_rate)
    return float(np.sqrt(np.trapezoid(psd, f)))


def relative_scale(ratio: float, beta: float, reference_std: float) -> float:
    """``s = ratio^2 / (beta reference_std)`` (per unit of the texture quantity)."""
    if not (ratio > 0 and beta > 0 and reference_std > 0):
        raise ValueError("ratio, beta and reference_std must be > 0")
    return float(ratio ** 2 / (beta * reference_std))

