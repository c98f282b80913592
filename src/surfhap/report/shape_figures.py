"""Figures for shape rendering (matplotlib object API, no pyplot state).

Each function takes ``ax`` (None, one Axes, or one Axes per panel:
:func:`surfhap.report.axes.figure_axes`) and returns the ``matplotlib.figure.Figure``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes

__all__ = ["plot_shape_result", "plot_top_view", "plot_calibration", "plot_profile", "plot_device_curve",
           "plot_scene"]


def plot_top_view(surface, ax=None, light=(0.0, 0.0, 1.0), path=None, n: int = 300) -> Figure:
    """Top view of ``surface`` shaded under ``light`` (vector towards the light), with an
    optional finger path ``(x (n,), y (n,))``."""
    from surfhap.shape.scan import top_view

    fig, (ax,) = figure_axes(ax, 1, (5, 5))
    shade, _, (x0, x1, y0, y1) = top_view(surface, np.asarray(light, dtype=float), n=n)
    img = np.ma.masked_invalid(shade)
    ax.imshow(img, origin="lower", extent=(x0 * 100, x1 * 100, y0 * 100, y1 * 100), cmap="gray", vmin=0, vmax=1,
              interpolation="nearest")
    if path is not None:
        px, py = path
        ax.plot(np.asarray(px) * 100, np.asarray(py) * 100, color="C1", lw=1.2)
        ax.plot(px[0] * 100, py[0] * 100, "o", color="C1", ms=4)
    ax.set(xlabel="x (cm)", ylabel="y (cm)", aspect="equal", title=f"{surface.name} (top view)")
    return fig


def _shape_layout(fig):
    gs = fig.add_gridspec(3, 2, width_ratios=(1.0, 1.5))
    ax = fig.add_subplot(gs[0, 1])
    return [fig.add_subplot(gs[:, 0]), ax, *(fig.add_subplot(gs[k, 1], sharex=ax) for k in (1, 2))]


def plot_shape_result(result, ax=None) -> Figure:
    """Top view with the path; height along the path; lateral force; intensity and ticks (4 panels)."""
    fig, (ax_top, ax, ax_f, ax_i) = figure_axes(ax, 4, (12, 7), layout=_shape_layout)
    if result.surface is not None:
        plot_top_view(result.surface, ax=ax_top, path=(result.x, result.y))
    t = result.t
    ax.plot(t, result.z * 100, color="C0", lw=1.2)
    ax.set(ylabel="hit height (cm)", title=f"{result.mesh}: {result.trajectory_name}")
    ax = ax_f
    ax.plot(t, result.force, color="C3", lw=1.0, label="lateral force -Fz dz/dr")
    ax.plot(t, result.fsq, color="C2", lw=0.8, alpha=0.8, label="signed sqrt (Fsq)")
    cal = result.calibration
    for v in (cal.fmin, cal.fmax):
        ax.axhline(v, color="C2", lw=0.6, ls=":")
    ax.axhline(0, color="k", lw=0.5)
    ax.set(ylabel="force (N) / Fsq")
    ax.legend(fontsize=8, loc="upper right")
    ax = ax_i
    ax.step(t, result.intensity, where="post", color="C1", lw=1.2, label="area intensity (eq. 9)")
    ticks = result.edge > 0
    if np.any(ticks):
        ax.vlines(t[ticks], 0, result.edge[ticks], color="C4", lw=1.5, label="edge tick Ie (eq. 11)")
        ax.plot(t[ticks], result.edge[ticks], "v", color="C4", ms=5)
    ax.set(xlabel="time (s)", ylabel="intensity", ylim=(0, 1.05))
    ax.legend(fontsize=8, loc="lower right")
    return fig


def plot_scene(scene, ax=None, resolution: float = 0.001) -> Figure:
    """Top view of one study scene under its light."""
    fig, (ax,) = figure_axes(ax, 1, (5, 5))
    plot_top_view(scene.surface(resolution), ax, light=scene.light_direction)
    ax.set_title(scene.name)
    return fig


def plot_calibration(cal, ax=None) -> Figure:
    """Histogram of the scanned Fsq and the chosen range."""
    fig, (ax,) = figure_axes(ax, 1, (6, 4))
    if cal.hist_counts:
        edges = np.asarray(cal.hist_edges)
        ax.stairs(np.asarray(cal.hist_counts), edges, fill=True, alpha=0.6)
    for v, lab in ((cal.fmin, "Fsq min"), (cal.fmax, "Fsq max")):
        ax.axvline(v, color="C3", lw=1.2)
        ax.text(v, ax.get_ylim()[1] * 0.95, lab, rotation=90, va="top", ha="right", fontsize=8)
    ax.set(xlabel="Fsq (sqrt N)", ylabel="count", yscale="log",
           title=f"{cal.mesh}: {cal.method}, {cal.n_samples} samples")
    return fig


def plot_profile(profile, ax=None) -> Figure:
    """A formative-study profile: geometry (cm), force (N) and intensity along the track."""
    fig, (ax,) = figure_axes(ax, 1, (6, 3.5))
    x = profile.x * 100
    ax.plot(x, profile.height * 100, color="C0", label="geometry (cm)")
    ax.plot(x, profile.force, color="C3", label="force (N)")
    ax.plot(x, profile.intensity, color="C1", label="intensity")
    ax.axhline(0, color="k", lw=0.5)
    ax.set(xlabel="x (cm)", title=profile.name)
    ax.legend(fontsize=8)
    return fig


def plot_device_curve(curve, ax=None) -> Figure:
    """The device's drive -> force curve over [0, its largest drive] (1 where unbounded)."""
    fig, (ax,) = figure_axes(ax, 1, (5, 3.5))
    u = np.linspace(0, curve.u_max if np.isfinite(curve.u_max) else 1.0, 101)
    ax.plot(u, curve.force(u))
    ax.set(xlabel=curve.input, ylabel="force (N)", title="device curve")
    return fig
