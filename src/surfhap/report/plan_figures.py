"""Figure of a gain plan: the renderable friction range over load (matplotlib object API)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes

__all__ = ["plot_gain_plans", "plan_table"]


def plot_gain_plans(plans, ax=None) -> Figure:
    """Two panels: the friction the display adds over the planned loads (band: over the
    speeds of the operating range, at the rendering gain), and the 99.9th-percentile drive
    voltage against v_max; several materials share the axes."""
    fig, (ax, ax_v) = figure_axes(ax, 2, (10, 4), ncols=2)
    for i, plan in enumerate(plans):
        lab = f"{plan.material} (G = {plan.rendering_gain:.2f})" if plan.material else f"G = {plan.rendering_gain:.2f}"
        lo, hi = plan.friction_low_n, plan.friction_high_n
        ax.fill_between(plan.loads, lo, hi, color=f"C{i}", alpha=0.35, lw=0)
        ax.plot(plan.loads, 0.5 * (lo + hi), color=f"C{i}", lw=1.2, label=lab)
        ax_v.plot(plan.loads, plan.peak_voltage, color=f"C{i}", lw=1.2, label=lab)
    p0 = plans[0]
    rng = p0.operating_range
    ax.set(xlabel="finger load (N)", ylabel="added friction (N)",
           title=f"renderable friction over {rng.speeds[0] * 1e3:g}-{rng.speeds[1] * 1e3:g} mm/s\n(band: over speeds, at the planned gain G)")
    if p0.display_max_n > 0 and p0.display_max_n < 1.5 * max(float(np.max(p.friction_high_n)) for p in plans):
        ax.axhline(p0.display_max_n, color="k", ls="--", lw=1)
        ax.text(p0.loads[-1], p0.display_max_n, f"display at v_max: {p0.display_max_n:.3f} N ", ha="right", va="bottom", fontsize=8)
        ax.set_ylim(0, 1.12 * p0.display_max_n)
    ax_v.axhline(p0.v_max, color="k", ls="--", lw=1)
    ax_v.text(p0.loads[0], p0.v_max, f" v_max {p0.v_max:g} V", va="bottom", fontsize=8)
    ax_v.set(xlabel="finger load (N)", ylabel="V", ylim=(0, 1.15 * p0.v_max),
             title=f"drive at the texture's {p0.percentile:g}th percentile\n(highest over speeds)")
    for a in (ax, ax_v):
        a.axvspan(0.26, 0.96, color="0.9", zorder=0)
        a.grid(True, lw=0.3)
    ax.text(0.61, ax.get_ylim()[1] * 0.02, "003 participants: 0.26-0.96 N", ha="center", va="bottom", fontsize=7, color="0.4")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, 0.9), title_fontsize=7,
              title="G = (alpha / alpha_calibrated)²: share of the\nlaw's friction the display adds (1 = all)")
    return fig


def plan_table(plans) -> list[list[str]]:
    """Rows (material, method, alpha, G, binding, headroom dB) for reports."""
    return [[p.material, p.method, f"{p.alpha:.1f}", f"{p.rendering_gain:.3f}", p.binding, f"{p.headroom_db:.2f}"]
            for p in plans if np.isfinite(p.alpha)]
