"""The textural PSD a render should show: what the spectrum panel and the fidelity checks
compare the rendered friction with."""

from __future__ import annotations

import numpy as np

from surfhap.render.drive import rendering_gain

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
    rate = r.texture_rate or r.control_rate
    f = np.asarray(freqs, dtype=float)
    psd = np.where(f < rate / 2, bank.psd_at(v, fn, f), 0.0)  # the TextureModel at (v, fn)
    per_unit = float(r.low_band.drive_law.texture_force_per_unit(v, fn)[0])  # N of target force per unit of texture
    return psd * (per_unit * rendering_gain(r.alpha, r.alpha_calibrated)) ** 2
