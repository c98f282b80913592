"""Figure of a psychometric-function fit (:class:`surfhap.lab.psychometric.PsychometricFit`)."""

from __future__ import annotations

import numpy as np

from surfhap.report.axes import figure_axes

__all__ = ["plot_psychometric"]


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
