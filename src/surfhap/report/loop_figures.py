"""The figure of a closed-loop comparison (:class:`surfhap.sim.closed_loop.LoopComparison`)."""

from __future__ import annotations

from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes

__all__ = ["plot_loop_comparison"]


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
