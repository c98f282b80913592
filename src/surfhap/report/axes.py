"""Small axis helpers shared by the figures (matplotlib object API)."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

__all__ = ["plain_log_ticks", "figure_axes", "carrier_resolved", "draw_drive"]


def figure_axes(ax, n: int, size: tuple[float, float], layout=None, **subplots) -> tuple[Figure, list[Axes]]:
    """The Figure and the ``n`` Axes a plot draws into (the ``ax`` of :meth:`surfhap.results.Result.plot`).

    ``ax`` None: a new constrained Figure of ``size`` inches whose Axes are ``layout(fig)``
    (a callable returning them) or ``fig.subplots(**subplots)``; one Axes (``n == 1``) or a
    sequence of ``n`` Axes: those, and their root figure."""
    if ax is None:
        fig = Figure(figsize=size, layout="constrained")
        axs = layout(fig) if layout is not None else fig.subplots(**subplots)
        return fig, list(np.ravel(axs))
    axs = [ax] if isinstance(ax, Axes) else list(np.ravel(np.asarray(ax, dtype=object)))
    if len(axs) != n:
        raise ValueError(f"this plot draws {n} panel(s): pass None, or {n} Axes, not {len(axs)}")
    return axs[0].get_figure(root=True), axs


def plain_log_ticks(axis) -> None:
    """Label a log axis (``ax.xaxis``) at 1, 2, 5 x 10^k in plain numbers (5, 10, 20 ...), with
    minor ticks unlabelled. Over less than a decade or two matplotlib's default labels every
    minor tick as '3x10^1', and the labels overlap."""
    axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def carrier_resolved(rate: float, carrier: float) -> bool:
    """True when a drive sampled at ``rate`` Hz draws its ``carrier`` Hz cycles legibly: at least
    8 samples per period (fewer, and the lines of a 10 kHz carrier at 20 kHz fill a solid block)."""
    return carrier <= 0 or rate / carrier >= 8


def draw_drive(ax, t: np.ndarray, v: np.ndarray, rate: float, carrier: float, **style) -> str:
    """Draw the drive ``v`` (V) over ``t`` (ms) on ``ax``: the samples when the carrier is resolved
    (:func:`carrier_resolved`), else its envelope, the min and max per carrier period filled.
    ``style``: colour, label ...; returns what was drawn ("drive" or "envelope")."""
    label = style.pop("label", "")
    if carrier_resolved(rate, carrier):
        ax.plot(t, v, lw=0.7, label=f"{label} drive".strip(), **style)
        return "drive"
    n = max(2, int(np.ceil(rate / carrier)))
    k = v.size // n * n
    lo, hi = v[:k].reshape(-1, n).min(axis=1), v[:k].reshape(-1, n).max(axis=1)
    ax.fill_between(t[:k:n], lo, hi, lw=0.6, alpha=0.6, step="post",
                    label=f"{label} envelope (min/max per {carrier:g} Hz period)".strip(), **style)
    return "envelope"
