"""Figure of :class:`surfhap.lab.compare.MaterialComparison` (matplotlib object API, no pyplot state)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes, plain_log_ticks
from surfhap.signal.bands import BandSplit

__all__ = ["plot_comparison"]


def _spectrum_band(p) -> tuple[float, float]:
    """(low, high) Hz where a material's added-friction spectrum means something: from the first
    Welch bin up to 0.4 x the texture's rate (its resampler rolls off above 0.45 fs; above that the
    spectrum is the numerical floor), or 0.4 x the control rate for a friction-only material."""
    rate = p.summary.get("texture_rate_hz") or p.summary["control_rate_hz"]
    return float(p.freqs[1]), 0.4 * float(rate)


def plot_comparison(comp, ax=None) -> Figure:
    """Friction over speed and load, spectra of the added friction (log-log, limited to each
    texture's band), voltage histograms (4 panels)."""
    fig, axs = figure_axes(ax, 4, (13, 7.5), nrows=2, ncols=2)
    a_v, a_l, a_s, a_h = axs
    lo, hi, p_lo, p_hi = np.inf, 0.0, np.inf, 0.0
    for i, p in enumerate(comp.profiles):
        c, ls = f"C{i}", ("-", "--", ":", "-.")[i % 4]  # a style too: materials with one law overlap
        a_v.plot(p.speeds * 1e3, p.mu_speed, color=c, ls=ls, label=p.name)
        a_l.plot(p.loads, p.force_load, color=c, ls=ls, label=p.name)
        f0, f1 = _spectrum_band(p)
        ok = (p.freqs >= f0) & (p.freqs <= f1) & (p.psd > 0)
        if ok.any():
            a_s.loglog(p.freqs[ok], p.psd[ok], color=c, ls=ls, lw=0.9, label=f"{p.name} (to {f1:g} Hz)")
            lo, hi = min(lo, f0), max(hi, f1)
            p_lo, p_hi = min(p_lo, float(p.psd[ok].min())), max(p_hi, float(p.psd[ok].max()))
        centres = 0.5 * (p.v_edges[1:] + p.v_edges[:-1])
        a_h.step(centres, p.v_hist, where="mid", color=c, ls=ls, label=f"{p.name} (mean {p.v_mean:.0f} V)")
    if hi > 0:
        a_s.axvline(BandSplit().cutoff, color="0.5", ls=":", lw=1, label="3.5 Hz band split")
        a_s.set(xlim=(lo, hi), ylim=(p_lo / 2, p_hi * 2))
        plain_log_ticks(a_s.xaxis)
    a_v.set(xlabel="speed (mm/s)", ylabel="friction coefficient", title=f"friction law at {comp.load:g} N")
    a_l.set(xlabel="normal force (N)", ylabel="friction force (N)",
            title=f"friction law at {comp.speed * 1e3:g} mm/s")
    a_s.set(xlabel="frequency (Hz)", ylabel="PSD (N$^2$/Hz)",
            title=f"added friction on the simulated display, {comp.speed * 1e3:g} mm/s, {comp.load:g} N")
    a_h.set(xlabel="|drive| (V)", ylabel="fraction of samples", title="drive voltage (after the safety stage)")
    for ax in axs:
        ax.legend(fontsize=8)
    fig.suptitle(f"strokes at {comp.speed * 1e3:g} mm/s, {comp.load:g} N, {comp.duration:g} s; "
                 f"each material by its default drive law ({', '.join(sorted({p.method for p in comp.profiles}))})")
    return fig
