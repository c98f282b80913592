"""The textural PSD a render should show: what the spectrum panel and the fidelity checks
compare the rendered friction with."""

from __future__ import annotations

import numpy as np

from surfhap.render.drive import rendering_gain
from surfhap.signal.ar import ar_psd

__all__ = ["expected_texture_psd"]


def expected_texture_psd(r, freqs: np.ndarray, v: float, fn: float) -> np.ndarray | None:
    """PSD (N^2/Hz) of the added friction's textural part of render ``r`` at speed ``v`` (m/s)
    and load ``fn`` (N), from its texture model; None for a method without texture.

    The texture's PSD times the squared force per texture unit of the rendered drive law (its
    own evaluation, :meth:`~surfhap.render.drive.DriveLaw.texture_force_per_unit`) and the
    squared rendering gain."""
    bank = r.texture_model
    if bank is None or not r.low_band.drive_law.uses_texture:
        return None
    rate = r.texture_rate or r.model_rate
    f = np.asarray(freqs, dtype=float)
    if hasattr(bank, "interpolate"):  # a bank interpolated over (speed, force), e.g. HaTT
        psd = bank.interpolate(v, fn).psd(rate, f)
    else:
        model = bank.models[int(bank.select(np.array([v]))[0])]
        psd = ar_psd(model.coefficients, model.variance, rate, f)
    psd = np.where(f < rate / 2, psd, 0.0)
    per_unit = float(r.low_band.drive_law.texture_force_per_unit(v, fn)[0])  # N of target force per unit of texture
    return psd * (per_unit * rendering_gain(r.alpha, r.alpha_calibrated)) ** 2
