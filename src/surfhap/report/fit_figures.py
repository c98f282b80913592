"""Figures of fitting results (matplotlib object API; no pyplot state).

Every function takes a result object from :mod:`surfhap.fit` and ``ax`` (None, one Axes, or
one Axes per panel: :func:`surfhap.report.axes.figure_axes`) and returns the
``matplotlib.figure.Figure``; computing and plotting stay separate calls.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes, plain_log_ticks
from surfhap.report.figures import plot_order_selection

__all__ = ["plot_band_split", "plot_friction_law", "plot_aic_curves", "plot_velocity_spectrum", "plot_spectra",
           "plot_similarity", "plot_friction_fit", "plot_accel_segments", "plot_accel_models", "plot_accel_aic",
           "plot_accel_fit"]


def plot_band_split(fit, ax=None) -> Figure:
    """CoF of the longest contact run, its low band (< cut-off) and high band (2 panels)."""
    fig, (a, b) = figure_axes(ax, 2, (9, 5), nrows=2, sharex=True)
    ex = fit.example
    a.plot(ex["t"], ex["cof"], lw=0.5, color="0.5", label="CoF")
    a.plot(ex["t"], ex["low"], lw=1.6, color="C0", label=f"low band (< {fit.cutoff:g} Hz)")
    a.set(ylabel="CoF", title=f"band split — {ex['source']}")
    a.legend(fontsize=8)
    b.plot(ex["t"], ex["high"], lw=0.5, color="C1")
    b.set(xlabel="time in contact run (s)", ylabel=f"CoF ≥ {fit.cutoff:g} Hz")
    return fig


def plot_friction_law(fit, ax=None) -> Figure:
    """Low-band CoF against normal force and speed, with the fitted quasi-static law (2 panels)."""
    fig, (a, b) = figure_axes(ax, 2, (11, 4.2), ncols=2)
    lb = fit.low_band
    law = fit.quasi_static.law
    for k, lab in enumerate(fit.participants):
        sel = lb["participant"] == k
        a.scatter(lb["fn"][sel], lb["mu"][sel], s=3, alpha=0.4, label=lab)
        b.scatter(lb["v"][sel] * 1e3, lb["mu"][sel], s=3, alpha=0.4)
    fn = np.linspace(max(lb["fn"].min(), 1e-3), lb["fn"].max(), 100)
    v_med = float(np.median(lb["v"]))
    fn_med = float(np.median(lb["fn"]))
    a.plot(fn, law.coefficient(fn, np.full_like(fn, v_med)), "k-", lw=2, label=f"law at {v_med * 1e3:.0f} mm/s")
    a.axhline(fit.coulomb.mu0, color="k", ls=":", label=f"Coulomb mu0 = {fit.coulomb.mu0:.3f}")
    a.set(xlabel="normal force (N)", ylabel="low-band CoF", title=f"quasi-static law ({fit.quasi_static.label})")
    a.legend(fontsize=7, markerscale=3)
    v = np.linspace(lb["v"].min(), lb["v"].max(), 100)
    b.plot(v * 1e3, law.coefficient(np.full_like(v, fn_med), v), "k-", lw=2, label=f"law at {fn_med:.2f} N")
    b.set(xlabel="speed (mm/s)", ylabel="low-band CoF", title=f"mean R² = {fit.quasi_static.r2:.2f}")
    b.legend(fontsize=7)
    return fig


def plot_aic_curves(fit, ax=None) -> Figure:
    """Order-selection curves, one panel per reference velocity."""
    n = max(len(fit.textures), 1)
    fig, axs = figure_axes(ax, n, (3.2 * n, 3.4), ncols=n)
    for ax, t in zip(axs, fit.textures):
        plot_order_selection(t.selection, ax=ax)
        ax.set_title(f"{t.reference_speed * 1e3:g} mm/s", fontsize=9)
    return fig


def plot_velocity_spectrum(tex, ax=None) -> Figure:
    """Measured (mean Welch over participants, and each participant) vs AR spectrum."""
    fig, (ax,) = figure_axes(ax, 1, (6, 4))
    f = tex.freqs
    sel = (f >= tex.band[0]) & (f > 0)
    for p in tex.participant_psds:
        ax.loglog(f[sel], p[sel], lw=0.5, color="0.75")
    ax.loglog(f[sel], tex.measured_psd[sel], lw=1.0, color="C0", label="measured (mean)")
    ax.loglog(f[sel], tex.model_psd[sel], "k--", lw=1.5, label=f"AR({tex.model.order})")
    ax.set(xlabel="frequency (Hz)", ylabel="PSD (1/Hz)",
           title=f"{tex.reference_speed * 1e3:g} mm/s — SI {tex.similarity_mean:.2f}")
    plain_log_ticks(ax.xaxis)
    ax.legend(fontsize=7)
    return fig


def plot_spectra(fit, ax=None) -> Figure:
    """Measured vs modelled spectra, one panel per reference velocity."""
    n = max(len(fit.textures), 1)
    fig, axs = figure_axes(ax, n, (3.4 * n, 3.6), ncols=n, sharey=True)
    for ax, t in zip(axs, fit.textures):
        plot_velocity_spectrum(t, ax=ax)
    return fig


def plot_similarity(fit, ax=None) -> Figure:
    """Similarity index per reference velocity: each participant and the mean ± SE."""
    fig, (ax,) = figure_axes(ax, 1, (6, 4))
    for t in fit.textures:
        x = t.reference_speed * 1e3
        ax.scatter(np.full(t.similarity.size, x), t.similarity, s=12, color="0.6")
        se = t.similarity_se
        ax.errorbar([x], [t.similarity_mean], yerr=[0 if np.isnan(se) else se], fmt="o", color="C3", capsize=4)
    ax.set(xlabel="reference velocity (mm/s)", ylabel="similarity index", ylim=(0, 1.02),
           title="measured vs modelled CoF spectra")
    return fig


def _friction_summary_layout(fig):
    sub = fig.subfigures(2, 2)
    return [*sub[0, 0].subplots(2, 1, sharex=True), *sub[0, 1].subplots(1, 2), sub[1, 0].subplots(), sub[1, 1].subplots()]


def plot_friction_fit(fit, ax=None, kind: str = "summary") -> Figure:
    """:meth:`surfhap.fit.material_fit.FrictionFit.plot`: ``kind`` "summary" (6 panels: band split,
    friction law, similarity, the middle velocity's spectrum) or one of the figures above."""
    table = {"band-split": plot_band_split, "friction-law": plot_friction_law, "aic": plot_aic_curves,
             "spectra": plot_spectra, "similarity": plot_similarity}
    if kind == "summary":
        fig, axs = figure_axes(ax, 6, (12, 8), layout=_friction_summary_layout)
        plot_band_split(fit, axs[0:2])
        plot_friction_law(fit, axs[2:4])
        plot_similarity(fit, axs[4])
        if fit.textures:
            plot_velocity_spectrum(fit.textures[len(fit.textures) // 2], ax=axs[5])
        return fig
    return _one_kind(table, kind, fit, ax)


def plot_accel_segments(fit, ax=None, source: str | None = None) -> Figure:
    """Acceleration of one recording with its change points, speed and force (2 panels)."""
    source = source or next(iter(fit.signals))
    sig = fit.signals[source]
    seg = fit.segmentations[source]
    fs = fit.sample_rate
    t = np.arange(sig["acceleration"].size) / fs
    fig, (a, b) = figure_axes(ax, 2, (10, 5), nrows=2, sharex=True)
    a.plot(t, sig["acceleration"], lw=0.4)
    for cp in seg.change_points:
        a.axvline(cp / fs, color="C3", lw=0.8)
    a.set(ylabel="acceleration (m/s²)", title=f"segmentation — {source} ({len(seg.segments)} segments)")
    b.plot(t, sig["speed"] * 1e3, color="C2", label="speed (mm/s)")
    b2 = b.twinx()
    b2.plot(t, sig["force"], color="C4")
    b2.set_ylabel("force (N)", color="C4")
    b.set(xlabel="time (s)", ylabel="speed (mm/s)")
    return fig


def plot_accel_models(fit, ax=None) -> Figure:
    """Triangulation over (speed, force) and the spectra of the fitted segment models (2 panels)."""
    fig, (a, b) = figure_axes(ax, 2, (11, 4.2), ncols=2)
    bank = fit.bank
    a.triplot(bank.speeds * 1e3, bank.forces, bank.triangles, color="0.6", lw=0.8)
    a.scatter(bank.speeds * 1e3, bank.forces, c=np.where(bank.variances > 0, "C0", "C7"), s=18)
    a.set(xlabel="speed (mm/s)", ylabel="normal force (N)", title="models and Delaunay triangles (grey: zero-variance edge)")
    f = np.linspace(1, fit.sample_rate / 2 * 0.98, 300)
    for s in fit.segments:
        b.semilogy(f, bank.psd_at(s.speed, s.force, f), lw=0.8, label=f"{s.speed * 1e3:.0f} mm/s, {s.force:.2f} N")
    b.set(xlabel="frequency (Hz)", ylabel="PSD ((m/s²)²/Hz)", title=f"segment models, AR({fit.order})")
    if len(fit.segments) <= 10:
        b.legend(fontsize=7)
    return fig


def plot_accel_aic(fit, ax=None) -> Figure:
    """The summed criterion against the common AR order, the chosen order marked."""
    fig, (ax,) = figure_axes(ax, 1, (6, 4))
    ax.plot(fit.orders[1:], fit.total_criterion[1:] - fit.total_criterion[1:].min())
    ax.axvline(fit.order, color="k", ls=":", label=f"chosen: {fit.order}")
    ax.set(xlabel="AR order p", ylabel=f"summed {fit.criterion.upper()} − min (≥ 0)", yscale="symlog")
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize=8)
    return fig


def _accel_summary_layout(fig):
    top, bottom = fig.subfigures(2, 1)
    return [*top.subplots(2, 1, sharex=True), *bottom.subplots(1, 2)]


def plot_accel_fit(fit, ax=None, kind: str = "summary", source: str | None = None) -> Figure:
    """:meth:`surfhap.fit.accel.AccelFit.plot`: ``kind`` "summary" (4 panels: segments of ``source``
    and models), "segments", "models" or "aic"."""
    if kind == "summary":
        fig, axs = figure_axes(ax, 4, (12, 8), layout=_accel_summary_layout)
        plot_accel_segments(fit, axs[:2], source)
        plot_accel_models(fit, axs[2:])
        return fig
    table = {"segments": lambda f, a: plot_accel_segments(f, a, source), "models": plot_accel_models,
             "aic": plot_accel_aic}
    return _one_kind(table, kind, fit, ax)


def _one_kind(table: dict, kind: str, fit, ax) -> Figure:
    """``table[kind](fit, ax)``, or a ValueError listing the kinds (with "summary")."""
    if kind not in table:
        raise ValueError(f"kind must be one of {', '.join(['summary', *table])}")
    return table[kind](fit, ax)
