"""The textural PSD a render should show: what the spectrum panel and the fidelity checks
compare the rendered friction with."""

from __future__ import annotations

import numpy as np

from surfhap.render.drive import texture_force

__all__ = ["expected_texture_psd"]


def expected_texture_psd(r, freqs: np.ndarray, v: float, fn: float) -> np.ndarray | None:
    """PSD (N^2/Hz) of the added friction's textural part of render ``r`` at speed ``v`` (m/s)
    and load ``fn`` (N), from its texture model; None for a method without texture.

    The texture's PSD times the squared force per texture unit of the rendered law
    (:func:`~surfhap.render.drive.texture_force`: relative scale, texture gain, beta) and the
    squared rendering gain (alpha / alpha_calibrated)^2."""
    bank = r.texture_model
    if bank is None or r.method in ("friction-only", "square"):
        return None
    rate = r.texture_rate or r.model_rate
    f = np.asarray(freqs, dtype=float)
    psd = np.where(f < rate / 2, bank.psd_at(v, fn, f), 0.0)  # the TextureModel at (v, fn)
    low = r.low_band  # the drive law's low band: its friction law and the load it uses (Zhao: constant)
    law = low.law if low is not None else r.friction_law
    mu_low = float(law.coefficient(np.array([fn]), np.array([v]))[0]) if law is not None else 0.0
    fn_c = float(low.load(np.array([fn]))[0]) if low is not None else fn
    per_unit = texture_force(bank.quantity, r.texture_relative_scale, r.method, 1.0, fn, mu_low, r.beta, r.texture_gain,
                             r.effective_mass, fn_c)  # N of target force per unit of texture
    gain = float((r.alpha / r.alpha_calibrated) ** 2)
    return psd * (per_unit * gain) ** 2
