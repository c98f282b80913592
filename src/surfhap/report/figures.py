"""Figures for texture rendering and model fitting (matplotlib, object API, no pyplot state).

Each function takes a result object and returns a ``matplotlib.figure.Figure``; saving is the
caller's business (``fig.savefig(path)``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from scipy.signal import welch

from surfhap.signal.bands import band_split_high_gain
from surfhap.signal.filters import band_split

__all__ = ["plot_render", "plot_order_selection", "plot_imu_fit", "render_spectrum"]

_CUTOFF = 3.5  # Hz, band split of Otake et al. 2022


def render_spectrum(result, settle: float = 0.5):
    """Welch PSD of the added friction's high band and the model's expectation.

    Returns freqs (m,), measured (m,) N^2/Hz, expected (m,) or None. The first ``settle``
    seconds (filter start-up) are skipped.
    """
    fs = result.model_rate
    start = min(int(settle * fs), max(0, result.t.size - 64))
    added = result.added_friction[start:]
    if added.size < 64 or _CUTOFF >= fs / 2:
        return np.zeros(0), np.zeros(0), None
    _, high = band_split(added, fs, _CUTOFF)
    nper = int(min(2048, 2 ** np.floor(np.log2(added.size // 4 or 1)) if added.size >= 256 else added.size))
    f, p = welch(high, fs=fs, nperseg=max(16, nper))
    expected = result.expected_texture_psd(f)
    if expected is not None:
        expected = expected * band_split_high_gain(f, fs, _CUTOFF)
    return f, p, expected


def plot_render(result, fig: Figure | None = None) -> Figure:
    """Four panels: friction over time, drive voltage, spectrum vs model, speed and load."""
    fig = fig or Figure(figsize=(11, 7.5), layout="constrained")
    axs = fig.subplots(2, 2)
    t = result.t
    touching = result.load > 0
    ax = axs[0, 0]
    span = min(1.0, float(t[-1])) if t.size else 1.0
    start = max(0.0, float(t[-1]) / 2 - span / 2) if t.size else 0.0
    w = (t >= start) & (t <= start + span)
    ax.plot(t[w], result.friction_sim[w], lw=0.8, color="C0", label="simulated friction")
    g = result.rendering_gain
    scaled = "" if abs(g - 1) < 1e-9 else f" × {g:.3g}"
    ax.plot(t[w], (result.mu_panel * result.load + g * result.target)[w], lw=0.8, color="C1", alpha=0.8, label=f"panel + target{scaled}")
    ax.plot(t[w], (result.mu_panel * result.load + g * result.mu_low * result.load * touching)[w], lw=1.2, color="k", ls="--",
            label=f"panel + low band{scaled}")
    ax.set(xlabel="time (s)", ylabel="lateral force (N)", title=f"{result.material} — {result.method}, {span:g} s window")
    ax.legend(loc="upper right", fontsize=8)
    ax = axs[0, 1]
    window = min(0.05, result.t_drive[-1] if result.t_drive.size else 0.05)
    mid = result.t_drive[-1] / 2 if result.t_drive.size else 0.0
    sel = (result.t_drive >= mid) & (result.t_drive <= mid + window)
    ax.plot(result.t_drive[sel] * 1e3, result.drive[sel], lw=0.6, label="drive (after safety)")
    tsel = (t >= mid) & (t <= mid + window)
    ax.plot(t[tsel] * 1e3, result.voltage[tsel], lw=1.2, color="C3", label="envelope")
    ax.set(xlabel="time (ms)", ylabel="voltage (V)", title=f"drive, {result.carrier:g} Hz carrier, {window * 1e3:g} ms")
    ax.legend(loc="upper right", fontsize=8)
    ax = axs[1, 0]
    f, p, e = render_spectrum(result)
    if f.size:
        top = 0.4 * (result.texture_rate or result.model_rate)  # the resamplers roll off above 0.45 fs
        band = (f >= _CUTOFF) & (f <= top)
        ax.loglog(f[band], p[band], lw=0.8, label="simulated (high band, Welch)")
        if e is not None:
            ax.loglog(f[band], e[band], lw=1.5, color="k", ls="--", label="AR model")
        ax.legend(fontsize=8)
    ax.set(xlabel="frequency (Hz)", ylabel="PSD (N²/Hz)", title="added friction above 3.5 Hz")
    ax = axs[1, 1]
    ax.plot(t, result.speed * 1e3, color="C2", lw=1)
    ax.set(xlabel="time (s)", ylabel="speed (mm/s)", title="finger")
    ax2 = ax.twinx()
    ax2.plot(t, result.load, color="C4", lw=1)
    ax2.set_ylabel("load (N)", color="C4")
    return fig


def plot_order_selection(selection, ax=None):
    """AIC and BIC against the AR order, the chosen order marked."""
    if ax is None:
        fig = Figure(figsize=(6, 4), layout="constrained")
        ax = fig.subplots()
    else:
        fig = ax.figure
    ax.plot(selection.orders, selection.aic - selection.aic.min(), label="AIC")
    ax.plot(selection.orders, selection.bic - selection.bic.min(), label="BIC")
    ax.axvline(selection.order, color="k", ls=":", label=f"chosen ({selection.criterion.upper()}): {selection.order}")
    ax.set(xlabel="AR order p", ylabel="criterion − min", yscale="symlog")
    ax.legend(fontsize=8)
    return fig


def plot_imu_fit(fit, fig: Figure | None = None) -> Figure:
    """Measured high-band spectrum vs the fitted AR spectrum, and the order selection."""
    fig = fig or Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    f, p = welch(fit.signal, fs=fit.sample_rate, nperseg=min(512, fit.signal.size))
    model = fit.bank.models[0].psd(fit.sample_rate, f) * band_split_high_gain(f, fit.sample_rate, fit.cutoff)
    sel = f > 0
    a.loglog(f[sel], p[sel], lw=0.8, label="recording (DFT321, high band)")
    a.loglog(f[sel], model[sel], "k--", lw=1.5, label=f"AR({fit.order})")
    a.set(xlabel="frequency (Hz)", ylabel="PSD ((m/s²)²/Hz)")
    a.legend(fontsize=8)
    plot_order_selection(fit.selection, ax=b)
    return fig
