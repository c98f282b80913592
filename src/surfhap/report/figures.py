"""Figures for texture rendering (open and closed loop) and model fitting (matplotlib, object API, no pyplot state).

Each function takes a result object and ``ax`` (None, one Axes, or one Axes per panel: see
:func:`surfhap.report.axes.figure_axes`) and returns the ``matplotlib.figure.Figure``; saving
is the caller's business (``fig.savefig(path)``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from scipy.signal import welch

from surfhap.report.axes import draw_drive, figure_axes, plain_log_ticks
from surfhap.signal.bands import BandSplit

__all__ = ["plot_render", "plot_order_selection", "plot_imu_fit", "plot_fidelity", "render_spectrum", "spectrum_of", "law_line",
           "plot_loop_comparison"]

_SPLIT = BandSplit()  # 3.5 Hz, the band split of Otake et al. 2022


def spectrum_of(added: np.ndarray, fs: float, expected_psd) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Welch PSD of the high band of ``added`` (n,) N at ``fs`` Hz and the model's expectation
    ``expected_psd(freqs)`` (or None) through the same band split: freqs, measured, expected."""
    if added.size < 64 or _SPLIT.cutoff >= fs / 2:
        return np.zeros(0), np.zeros(0), None
    high = _SPLIT.high(added, fs)
    nper = int(min(2048, 2 ** np.floor(np.log2(added.size // 4 or 1)) if added.size >= 256 else added.size))
    f, p = welch(high, fs=fs, nperseg=max(16, nper))
    expected = expected_psd(f)
    if expected is not None:
        expected = expected * _SPLIT.high_gain(f, fs)
    return f, p, expected


def render_spectrum(result, settle: float = 0.5):
    """Welch PSD of the added friction's high band and the model's expectation.

    Returns freqs (m,), measured (m,) N^2/Hz, expected (m,) or None. The first ``settle``
    seconds (filter start-up) are skipped.
    """
    fs = result.control_rate
    start = min(int(settle * fs), max(0, result.t.size - 64))
    return spectrum_of(result.added_friction[start:], fs, result.expected_texture_psd)


def law_line(pv) -> np.ndarray:
    """(w,) N, the dashed law line of the render figure over ``pv.win_t``: the bare panel's
    friction plus the rendering gain times the low band of the method's own drive law
    (``pv.win_low``, e.g. Zhao's mu0 times his constant 1.6 N, not the measured load)."""
    return pv.mu_panel * pv.win_load + pv.rendering_gain * pv.win_low


def plot_render(pv, ax=None) -> Figure:
    """Four panels: friction over time, drive voltage, spectrum vs model, speed and load.

    ``pv``: a :class:`~surfhap.render.preview.RenderPreview`, the bounded copy a render keeps
    for its figure (``RenderResult.plot()`` and the streamed render pass theirs)."""
    if ax is None:  # fixed margins: constrained layout took half of the figure's time (batch jobs draw one each)
        fig = Figure(figsize=(11, 7.5))
        fig.subplots_adjust(left=0.065, right=0.935, bottom=0.07, top=0.955, wspace=0.24, hspace=0.3)
        ax = fig.subplots(2, 2)
    fig, axs = figure_axes(ax, 4, ())
    ax = axs[0]
    t = pv.win_t
    ax.plot(t, pv.win_friction, lw=0.8, color="C0", label="simulated friction")
    g = pv.rendering_gain
    scaled = "" if abs(g - 1) < 1e-9 else f" × {g:.3g}"
    ax.plot(t, pv.mu_panel * pv.win_load + g * pv.win_target, lw=0.8, color="C1", alpha=0.8, label=f"panel + target{scaled}")
    ax.plot(t, law_line(pv), lw=1.2, color="k", ls="--", label=f"panel + low band{scaled}")
    on = pv.load_max > 0
    scan = f", {np.median(pv.load_max[on]):.2g} N, {np.median(pv.speed_max[on]) * 1e3:.0f} mm/s" if on.any() else ""  # medians
    ax.set(xlabel="time (s)", ylabel="lateral force (N)")
    ax.set_title(f"{pv.material} — {pv.method}{scan}, {pv.span:g} s", fontsize=11)
    ax.legend(loc="upper right", fontsize=8)
    ax = axs[1]
    rate = 1.0 / float(np.median(np.diff(pv.drv_t))) if pv.drv_t.size > 1 else 0.0
    draw_drive(ax, pv.drv_t * 1e3, pv.drv, rate, pv.carrier, color="C0", label="after safety:")
    ax.plot(pv.env_t * 1e3, pv.env, lw=1.2, color="C3", label="voltage envelope of the law")
    ax.set(xlabel="time (ms)", ylabel="voltage (V)", title=f"drive, {pv.carrier:g} Hz carrier, {pv.window * 1e3:g} ms")
    ax.legend(loc="upper right", fontsize=8)
    ax = axs[2]
    f, p, e = spectrum_of(pv.spec_added, pv.control_rate, pv.expected_psd)
    if f.size:
        top = 0.4 * (pv.texture_rate or pv.control_rate)  # the resamplers roll off above 0.45 fs
        band = (f >= _SPLIT.cutoff) & (f <= top)
        ax.loglog(f[band], p[band], lw=0.8, label="simulated (high band, Welch)")
        if e is not None:
            ax.loglog(f[band], e[band], lw=1.5, color="k", ls="--", label="AR model")
        ax.legend(fontsize=8)
        plain_log_ticks(ax.xaxis)
    ax.set(xlabel="frequency (Hz)", ylabel="PSD (N²/Hz)", title="added friction above 3.5 Hz")
    ax = axs[3]
    sp = ax.fill_between(pv.col_t, pv.speed_min * 1e3, pv.speed_max * 1e3, color="C2", lw=1, step="post",
                         label="speed (mm/s, left)")
    ax.set(xlabel="time (s)", ylabel="speed (mm/s)", title="finger (min/max per column)")
    ax2 = ax.twinx()
    ld = ax2.fill_between(pv.col_t, pv.load_min, pv.load_max, color="C4", lw=1, alpha=0.6, step="post",
                          label="load (N, right)")
    ax2.set_ylabel("load (N)", color="C4")
    ax2.legend(handles=[sp, ld], loc="lower right", fontsize=8)
    return fig


def plot_order_selection(selection, ax=None) -> Figure:
    """AIC and BIC against the AR order, the chosen order marked."""
    fig, (ax,) = figure_axes(ax, 1, (6, 4))
    ax.plot(selection.orders, selection.aic - selection.aic.min(), label="AIC")
    ax.plot(selection.orders, selection.bic - selection.bic.min(), label="BIC")
    ax.axvline(selection.order, color="k", ls=":", label=f"chosen ({selection.criterion.upper()}): {selection.order}")
    ax.set(xlabel="AR order p", ylabel="criterion − min (≥ 0)", yscale="symlog")
    ax.set_ylim(bottom=0.0)  # symlog's margin would add negative ticks to a non-negative quantity
    ax.legend(fontsize=8)
    return fig


def plot_imu_fit(fit, ax=None) -> Figure:
    """Measured high-band spectrum vs the fitted AR spectrum, and the order selection (2 panels)."""
    fig, (a, b) = figure_axes(ax, 2, (10, 4), ncols=2)
    f, p = welch(fit.signal, fs=fit.sample_rate, nperseg=min(512, fit.signal.size))
    model = fit.bank.models[0].psd(fit.sample_rate, f) * BandSplit(cutoff=fit.cutoff).high_gain(f, fit.sample_rate)
    sel = f > 0
    a.loglog(f[sel], p[sel], lw=0.8, label="recording (DFT321, high band)")
    a.loglog(f[sel], model[sel], "k--", lw=1.5, label=f"AR({fit.order})")
    a.set(xlabel="frequency (Hz)", ylabel="PSD ((m/s²)²/Hz)")
    plain_log_ticks(a.xaxis)
    a.legend(fontsize=8)
    plot_order_selection(fit.selection, ax=b)
    return fig


def plot_fidelity(metrics, ax=None) -> Figure:
    """The fidelity metrics of one render (:mod:`surfhap.render.fidelity`) as bars; the ones
    not measured (None) are left out."""
    fig, (ax,) = figure_axes(ax, 1, (6, 3))
    d = metrics.summary()
    shown = [k for k in ("saturated_fraction", "clipped_fraction", "low_band_error", "texture_correlation",
                         "voltage_ratio", "ratio_error") if d[k] is not None]
    ax.barh(shown, [d[k] for k in shown], color="C0")
    ax.axvline(0, color="k", lw=0.8)
    ax.set(xlabel="value", title=f"{metrics.material} — {metrics.method}, G = {metrics.rendering_gain:.3g}")
    return fig


def plot_loop_comparison(c, ax=None) -> Figure:
    """Octave-band power of the texture band (dB), open and closed loop, with the low-band
    RMS errors of both in the title."""
    fig, (ax,) = figure_axes(ax, 1, (6, 3.5))
    for figures, label, style in ((c.open, "open loop", "o-"), (c.closed, "closed loop", "s--")):
        ax.semilogx(figures.centres, figures.texture_band, style, label=label)
    ax.set(xlabel="octave band centre (Hz)", ylabel="texture band power (dB re 1 N²/Hz)",
           title=f"low-band RMS error: open {c.open.low_band_rms * 1e3:.3g} mN, closed {c.closed.low_band_rms * 1e3:.3g} mN "
                 f"(ratio {c.ratio:.2f})")
    ax.legend()
    return fig
