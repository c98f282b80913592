"""Figures for the lab tools: calibration fits, confusion matrices, proportions with intervals,
real-vs-virtual rating scatter, staircases, ANOVAs, psychometric fits and material comparisons
(matplotlib object API, no pyplot state).

Each function takes ``ax`` (None, one Axes, or one Axes per panel:
:func:`surfhap.report.axes.figure_axes`) and returns the ``matplotlib.figure.Figure``; saving
is the caller's business.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes, plain_log_ticks
from surfhap.signal.bands import BandSplit

__all__ = ["plot_calibration", "plot_confusion", "plot_proportions", "plot_rating_scatter", "plot_staircase",
           "plot_anova", "plot_psychometric", "plot_comparison"]


def plot_calibration(cal, ax=None) -> Figure:
    """Static increase and vibration amplitude vs level with their quadratic fits; residuals (2 panels)."""
    fig, (ax_fit, ax_res) = figure_axes(ax, 2, (10, 4), ncols=2)
    x = np.linspace(0.0, cal.level_max, 200)
    unit = "V" if cal.input == "voltage" else ""
    for fit, label, colour in ((cal.static_fit, "static friction increase", "C0"),
                               (cal.amplitude_fit, "p-p vibration amplitude", "C1")):
        ax_fit.plot(fit.x, fit.y, "o", color=colour, label=label)
        ax_fit.plot(x, fit(x), "-", color=colour, lw=1)
        ax_res.plot(fit.x, fit.residuals * 1e3, "o-", color=colour, label=label)
    if cal.k is not None:
        volts = x if cal.input == "voltage" else x * cal.volts_per_unit
        ax_fit.plot(x, cal.mu_panel * cal.k * volts ** 2, "--", color="k", lw=1,
                    label=f"mu k V^2 (k = {cal.k:.3g} N/V^2)")
    ax_fit.set(xlabel=f"{cal.input} {unit}".strip(), ylabel="force (N)",
               title=f"device curve ({cal.curve}); mu_panel = {cal.mu_panel:.3f}")
    ax_fit.legend(fontsize=8)
    ax_res.axhline(0, color="0.5", lw=0.8)
    ax_res.set(xlabel=f"{cal.input} {unit}".strip(), ylabel="residual (mN)", title="quadratic fit residuals")
    return fig


def plot_confusion(result, ax=None) -> Figure:
    """Confusion matrix (row = presented, column = answered) as proportions per row."""
    fig, (ax,) = figure_axes(ax, 1, (5.5, 4.5))
    p = result.proportions
    im = ax.imshow(p, cmap="Blues", vmin=0, vmax=1)
    labels = list(result.labels)
    ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right")
    ax.set_yticks(range(len(labels)), labels)
    for i in range(p.shape[0]):
        for j in range(p.shape[1]):
            ax.text(j, i, f"{p[i, j]:.2f}", ha="center", va="center", color="w" if p[i, j] > 0.6 else "k", fontsize=8)
    ax.set(xlabel="answered", ylabel="presented",
           title=f"{result.title}: trials pooled, n = {int(result.counts.sum())} (overall {result.accuracy:.2f})")
    fig.colorbar(im, ax=ax, shrink=0.8, label="proportion")
    return fig


def plot_proportions(result, ax=None, chance: float | None = None) -> Figure:
    """Bar chart of proportions with their confidence intervals (within [0, 1]); the title says
    whether the bars pool trials ("trials pooled, n = ...") or average participants ("mean of N
    participants")."""
    fig, (ax,) = figure_axes(ax, 1, (6, 3.5))
    p, lo, hi = (np.asarray(a, dtype=float) for a in (result.proportion, result.ci_low, result.ci_high))
    x = np.arange(p.size)
    ax.bar(x, p, color="C0", alpha=0.8)
    ax.errorbar(x, p, yerr=np.maximum([p - lo, hi - p], 0.0), fmt="none", ecolor="k", capsize=4)  # hi is 1 - 1e-16 at n/n
    if chance is not None:
        ax.axhline(chance, color="C3", ls="--", lw=1, label=f"chance {chance:.2f}")
        ax.legend(fontsize=8)
    ax.set_xticks(x, list(result.labels), rotation=20, ha="right")
    if result.method == "participants":
        n = sorted({int(k) for k in result.n})
        what = (f"mean of {n[0] if len(n) == 1 else f'{n[0]}-{n[-1]}'} participants, "
                f"{result.confidence:.0%} bootstrap CI over participants")
    else:
        what = (f"trials pooled, n = {int(np.sum(result.n))}, "
                f"{'Wilson' if result.method == 'wilson' else 'Clopper-Pearson'} {result.confidence:.0%} CI")
    ax.set(ylim=(0, 1.05), ylabel="mean proportion" if result.method == "participants" else "proportion",
           title=f"{result.title}\n{what}")
    return fig


def plot_rating_scatter(result, ax=None) -> Figure:
    """Mean rating of each material, real (x) vs virtual (y), with the correlation."""
    fig, (ax,) = figure_axes(ax, 1, (4.5, 4.5))
    ax.plot(result.x, result.y, "o")
    for xi, yi, lab in zip(result.x, result.y, result.labels):
        ax.annotate(str(lab), (xi, yi), fontsize=7, xytext=(3, 3), textcoords="offset points")
    lo = min(np.min(result.x), np.min(result.y))
    hi = max(np.max(result.x), np.max(result.y))
    ax.plot([lo, hi], [lo, hi], color="0.6", lw=0.8)
    ax.set(xlabel=f"{result.x_name}", ylabel=f"{result.y_name}",
           title=f"r = {result.r:.3f}, p = {result.p:.2g} (n = {result.n})")
    return fig


def plot_staircase(result, ax=None) -> Figure:
    """Levels of a staircase run, reversals marked, threshold estimate as a line."""
    fig, (ax,) = figure_axes(ax, 1, (6, 3.5))
    lv = np.asarray(result.levels)
    resp = np.asarray(result.responses, dtype=bool)
    x = np.arange(1, lv.size + 1)
    ax.plot(x, lv, "-", color="0.6", lw=0.8)
    ax.plot(x[resp], lv[resp], "o", color="C0", ms=4, label="yes / correct")
    ax.plot(x[~resp], lv[~resp], "o", mfc="none", color="C3", ms=4, label="no / wrong")
    rev = np.asarray(result.reversal_trials, dtype=int)
    if rev.size:
        ax.plot(rev + 1, lv[rev], "x", color="k", label="reversal")
    if result.threshold is not None:
        ax.axhline(result.threshold, color="C2", ls="--", label=f"threshold {result.threshold:.3g}")
    ax.set(xlabel="trial", ylabel="level", title="staircase")
    ax.legend(fontsize=8)
    return fig


def plot_anova(an, ax=None, alpha: float = 0.05) -> Figure:
    """F of every effect of an ANOVA (``AnovaResult``) as horizontal bars, each labelled with its
    df and p; effects with p < ``alpha`` filled, the others hollow."""
    fig, (ax,) = figure_axes(ax, 1, (6, 0.5 + 0.45 * len(an.rows)))
    names = [r[0] for r in an.rows]
    y = np.arange(len(names))
    for k, (_, f, d1, d2, p) in enumerate(an.rows):
        sig = p < alpha
        ax.barh(k, f, color="C0" if sig else "none", edgecolor="C0")
        ax.annotate(f" F({d1:g}, {d2:g}) = {f:.2f}, p = {p:.3g}", (f, k), va="center", fontsize=8)
    ax.set_yticks(y, names)
    ax.invert_yaxis()
    ax.set(xlabel="F", title=f"{an.method}: {an.depvar} ({an.subjects} subjects; filled: p < {alpha:g})")
    ax.margins(x=0.6)
    return fig


def plot_psychometric(fit, ax=None):
    """Proportion correct per level (marker area ~ trials), the fitted curve, and the threshold
    with its bootstrap interval if there is one; returns the Figure."""
    fig, (ax,) = figure_axes(ax, 1, (5.0, 3.5))
    levels, trials = np.asarray(fit.levels, float), np.asarray(fit.trials, float)
    seen = trials > 0
    ax.scatter(levels[seen], fit.correct[seen] / trials[seen], s=20 + 80 * trials[seen] / trials.max(),
               color="C0", alpha=0.7, label="observed")
    lo, hi = levels.min(), levels.max()
    x = np.geomspace(lo, hi, 200) if fit.shape == "weibull" else np.linspace(lo, hi, 200)
    ax.plot(x, fit.psi(x), color="C1", label=f"{fit.shape} fit")
    if fit.shape == "weibull":
        ax.set_xscale("log")
    y = float(fit.psi(fit.threshold))
    ax.axvline(fit.threshold, color="0.5", lw=0.8, ls="--")
    if "threshold" in fit.ci:
        t_lo, t_hi = fit.ci["threshold"]
        ax.errorbar([fit.threshold], [y], xerr=[[fit.threshold - t_lo], [t_hi - fit.threshold]],
                    fmt="o", color="k", capsize=3, label="threshold, 95 % CI")
    ax.set_ylim(min(fit.guess, 0.5) - 0.05, 1.05)
    ax.set_xlabel("stimulus level")
    ax.set_ylabel("proportion correct")
    ax.legend(fontsize="small")
    return fig


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
        # where the spectrum means something: from the first Welch bin to 0.4 x the texture's rate (its
        # resampler rolls off above 0.45 fs: above, the numerical floor), or the control rate's (friction only)
        f0, f1 = float(p.freqs[1]), 0.4 * float(p.summary.get("texture_rate_hz") or p.summary["control_rate_hz"])
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
