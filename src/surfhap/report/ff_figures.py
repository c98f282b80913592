"""Figures of a force-feedback simulation (matplotlib object API, no pyplot state).

Each function takes ``ax`` (None, one Axes, or one Axes per panel:
:func:`surfhap.report.axes.figure_axes`) and returns the ``matplotlib.figure.Figure``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes

__all__ = ["plot_ff_result", "plot_ff_top_view"]


def plot_ff_result(result, ax=None) -> Figure:
    """Forces, screen motion, finger-screen relative sliding and effect switches over time (4 panels)."""
    fig, axs = figure_axes(ax, 4, (11, 9), nrows=4, sharex=True, height_ratios=(1.0, 1.0, 1.0, 0.6))
    t = result.t - result.t[0]
    for i, lab in enumerate("xyz"):
        axs[0].plot(t, result.force[:, i], lw=0.8, label=f"F{lab}")
        axs[1].plot(t, result.screen[:, i] * 1e3, lw=0.8, label=f"X_t,{lab}")
    axs[0].set(ylabel="force (N)", title=f"{result.name}: force sent to the device (after the safety stage)")
    axs[1].set(ylabel="screen (mm)", title="screen position relative to the workspace centre X0")
    fing = np.hypot(result.finger_v[:, 0], result.finger_v[:, 1])
    slide = np.hypot(result.sliding[:, 0], result.sliding[:, 1])
    touch = result.touched
    axs[2].plot(t, np.where(touch, fing, np.nan) * 1e3, lw=0.8, color="0.5", label="finger speed (world)")
    axs[2].plot(t, np.where(touch, slide, np.nan) * 1e3, lw=0.9, color="C3", label="finger-screen sliding speed")
    axs[2].set(ylabel="speed (mm/s)", title="relative sliding")
    axs[2].set_ylim(bottom=0.0)
    axs[2].ticklabel_format(axis="y", useOffset=False)
    names = result.effects or []
    for b, name in enumerate(names):
        on = (result.mask >> b) & 1
        axs[3].fill_between(t, b + 0.1, b + 0.1 + 0.8 * on, step="post", color=f"C{b}", lw=0)
    axs[3].fill_between(t, -0.9, -0.9 + 0.8 * (result.mask == 0), step="post", color="0.6", lw=0)
    axs[3].set_yticks(np.arange(-1, len(names)) + 0.5, ["idle", *names])
    axs[3].set(xlabel="time (s)", title="active effects", ylim=(-1, max(1, len(names))))
    bt = result.button
    if bt is not None and result.buttons:  # GUI button presses: shaded spans, named
        down = bt >= 0
        axs[3].set_title("active effects; GUI button presses shaded")
        for ax in axs[:2]:
            ax.fill_between(t, 0, 1, where=down, step="post", color="C2", alpha=0.15, lw=0,
                            transform=ax.get_xaxis_transform())
        for ts, name in result.presses():
            axs[1].annotate(f"press {name}", (ts - result.t[0], 1.0), xycoords=("data", "axes fraction"),
                            fontsize=8, color="C2", va="top", rotation=90)
    for ax in axs[:3]:
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
    return fig


def plot_ff_top_view(result, ax=None, picture: np.ndarray | None = None,
                     size: tuple[float, float] | None = None) -> Figure:
    """The scene's picture (content coordinates) with the finger's path and the screen's path."""
    fig, (ax,) = figure_axes(ax, 1, (6, 5))
    if picture is not None and size is not None:
        ax.imshow(picture, extent=(0, size[0] * 100, size[1] * 100, 0), cmap="gray", vmin=0, vmax=1)
    m = result.touched
    ax.plot(result.finger[m, 0] * 100, result.finger[m, 1] * 100, color="C1", lw=1.0, label="finger (world)")
    ax.plot(result.finger_est[m, 0] * 100, result.finger_est[m, 1] * 100, color="C0", lw=0.6, ls="--",
            label="engine estimate")
    ax.set(xlabel="x (cm)", ylabel="y (cm)", aspect="equal", title=f"{result.name}: finger path over the content")
    ax.legend(loc="lower right", fontsize=8)
    return fig
