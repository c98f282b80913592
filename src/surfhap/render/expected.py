"""The textural PSD a render should show: what the spectrum panel and the fidelity checks
compare the rendered friction with."""

from __future__ import annotations

import numpy as np

from surfhap.signal.ar import ar_psd

__all__ = ["expected_texture_psd"]


def expected_texture_psd(r, freqs: np.ndarray, v: float, fn: float) -> np.ndarray | None:
    """PSD (N^2/Hz) of the added friction's textural part of render ``r`` at speed ``v`` (m/s)
    and load ``fn`` (N), from its texture model; None for a method without texture."""
    bank = r.texture_model
    if bank is None or r.method in ("friction-only", "square"):
        return None
    rate = r.texture_rate or r.model_rate
    f = np.asarray(freqs, dtype=float)
    if hasattr(bank, "interpolate"):  # a bank interpolated over (speed, force), e.g. HaTT
        psd = bank.interpolate(v, fn).psd(rate, f)
    else:
        model = bank.models[int(bank.select(np.array([v]))[0])]
        psd = ar_psd(model.coefficients, model.variance, rate, f)
    psd = np.where(f < rate / 2, psd, 0.0)
    gain = float((r.alpha / r.alpha_calibrated) ** 2)
    if r.method == "zhao":
        load = fn if r.constant_load is None else r.constant_load
        scale = r.effective_mass if bank.quantity == "acceleration" else load
    else:
        per_load = 1.0 if bank.quantity == "cof" else r.effective_mass / fn
        scale = r.beta * per_load * fn
    return psd * (scale * gain) ** 2
