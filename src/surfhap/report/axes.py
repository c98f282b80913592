"""Small axis helpers shared by the figures (matplotlib object API)."""

from __future__ import annotations

from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

__all__ = ["plain_log_ticks"]


def plain_log_ticks(axis) -> None:
    """Label a log axis (``ax.xaxis``) at 1, 2, 5 x 10^k in plain numbers (5, 10, 20 ...), with
    minor ticks unlabelled. Over less than a decade or two matplotlib's default labels every
    minor tick as '3x10^1', and the labels overlap."""
    axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())
