"""The demo report: figures and ``report.html`` from :func:`surfhap.sim.demo.run_demo`'s result.

Reads results only; the renders are computed in :mod:`surfhap.sim.demo`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

from surfhap.models.texture import TextureBank
from surfhap.report.axes import figure_axes, plain_log_ticks
from surfhap.report.figures import render_spectrum
from surfhap.report.html import Page
from surfhap.signal.bands import spectral_deviation_db

if TYPE_CHECKING:
    from surfhap.sim.demo import DemoResults

__all__ = ["write_demo_report"]


def _speed_figure(name: str, runs) -> Figure:
    fig, (a, b, c) = figure_axes(None, 3, (11, 3.6), ncols=3)
    for r in runs:
        v = float(np.median(r.speed[r.load > 0]))
        lab = f"{v * 1e3:.0f} mm/s"
        sel = r.t >= r.t[-1] - 0.5
        a.plot(r.t[sel], r.added_friction[sel], lw=0.7, label=lab)
        band = np.zeros(0, dtype=bool)
        if r.texture_model is not None:
            f, p, e = render_spectrum(r)
            band = (f >= 3.5) & (f <= 0.4 * (r.texture_rate or r.control_rate))
        if band.any():
            line, = b.loglog(f[band], p[band], lw=0.7, label=lab)
            if e is not None:
                b.loglog(f[band], e[band], lw=1.3, ls="--", color=line.get_color())
        sel2 = (r.t_drive >= 1.0) & (r.t_drive < 1.01)
        c.plot((r.t_drive[sel2] - 1.0) * 1e3, r.drive[sel2], lw=0.7, label=lab)
    fig.suptitle(name)
    a.set(title="added friction, last 0.5 s", xlabel="time (s)", ylabel="N")
    b.set(title="high band: simulated (solid) vs model (dashed)", xlabel="Hz", ylabel="N²/Hz")
    if b.get_xscale() == "log":
        plain_log_ticks(b.xaxis)
    if runs[0].texture_model is None:
        b.text(0.5, 0.5, "friction-only:\nno texture to compare", ha="center", va="center", transform=b.transAxes)
        b.set_xticks([])
        b.set_yticks([])
    elif isinstance(runs[0].texture_model, TextureBank) and len(runs[0].texture_model.models) == 1:
        b.set_title("high band (one speed-independent model:\nthe speeds overlap)")
    c.set(title="drive after safety, 10 ms", xlabel="ms", ylabel="V")
    for ax in (a, b, c):
        if ax.lines:
            ax.legend(fontsize=7)
    return fig


def _means(r) -> tuple[float, float, float]:
    """(median touching speed m/s, mean of G mu_low fn N, mean simulated added friction N) after 0.5 s."""
    warm = r.t > 0.5
    return (float(np.median(r.speed[r.load > 0])), r.rendering_gain * float(np.mean((r.mu_low * r.load)[warm])),
            float(np.mean(r.added_friction[warm])))


def _law_figure(results) -> Figure:
    fig, (ax,) = figure_axes(None, 1, (7, 4.2))
    for i, (name, runs) in enumerate(results.items()):
        v, law, sim = np.array([_means(r) for r in runs]).T
        ax.plot(v * 1e3, law, "-", color=f"C{i}", lw=1)
        ax.plot(v * 1e3, sim, "o", color=f"C{i}", label=name)
    ax.set(xlabel="scan speed (mm/s)", ylabel="mean added friction (N)",
           title="simulated display (dots) vs G·mu_low(fn, v)·fn (lines)")
    ax.legend(fontsize=8)
    return fig


def _fidelity_rows(grid) -> tuple[list[str], list[list[str]]]:
    head = ["material", "load N", "speed mm/s", "method", "gain G", "saturated", "clipped", "low band vs G·law",
            "texture r", "voltage ratio", "target", "ratio error", "targets met"]
    rows = []
    for r, m in grid:
        ok = (m.saturated_fraction <= 0.001 and abs(m.low_band_error) <= 0.02
              and (m.texture_correlation is None or m.texture_correlation >= 0.95)
              and (m.ratio_error is None or abs(m.ratio_error) <= 0.2))
        rows.append([m.material, f"{m.load:.2f}", f"{m.speed * 1e3:.0f}", m.method, f"{m.rendering_gain:.3f}",
                     f"{m.saturated_fraction:.2%}", f"{m.clipped_fraction:.2%}", f"{100 * m.low_band_error:+.2f} %",
                     "-" if m.texture_correlation is None else f"{m.texture_correlation:.4f}", f"{m.voltage_ratio:.3f}",
                     "-" if m.target_voltage_ratio is None else f"{m.target_voltage_ratio:g}",
                     "-" if m.ratio_error is None else f"{100 * m.ratio_error:+.1f} %", "yes" if ok else "NO"])
    return head, rows


def write_demo_report(results: DemoResults, out_dir: str | Path) -> Path:
    """Write the gain plans, the fidelity table, one figure per material and ``report.html``;
    returns its path."""
    from surfhap.exchange.materials import load_material
    from surfhap.report.plan_figures import plan_table, plot_gain_plans

    settings = results.settings
    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    page = Page("surfhap demo: built-in materials on the simulated electrostatic display")
    first = next(iter(results.plans.values()))
    page.paragraph(f"Each material is rendered by its default method along straight scans at "
                   f"{', '.join(f'{s * 1e3:g}' for s in settings.speeds)} mm/s under loads of "
                   f"{', '.join(f'{x:g}' for x in settings.loads)} N (003 Sec. II: 0.26-0.96 N) for "
                   f"{settings.duration:g} s each, through the safety stage ({first.v_max:g} V limit) onto the simulated "
                   f"display (display: {next(iter(results.renders.values()))[0].display_info['source']}).")
    page.heading("Gain plan: what the display can render over the operating range")
    page.paragraph(f"alpha is planned per material so that the friction law plus the texture's {first.percentile:g}th "
                   f"percentile stays under v_max over loads {first.operating_range.loads[0]:g}-{first.operating_range.loads[1]:g} N "
                   f"and speeds {first.operating_range.speeds[0]:g}-{first.operating_range.speeds[1]:g} m/s; the display then adds "
                   f"G = (alpha / alpha_calibrated)^2 times the law's force (docs/texture.md).")
    page.figure(plot_gain_plans(list(results.plans.values())), out, "figures/gain_plan.png",
                "renderable friction range over load", dpi=100)
    page.table(["material", "method", "alpha V/sqrt(N)", "gain G", "bound by", "headroom dB"], plan_table(results.plans.values()))
    page.heading("Fidelity over load x speed x material")
    page.paragraph("Targets: saturated <= 0.1 %; low-band mean of the added friction within 2 % of G·mu_p(fn, v)·fn; "
                   "band-passed (>= 3.5 Hz) friction follows the texture the law asked for with r >= 0.95; "
                   "texture:friction voltage ratio within 20 % of the material's calibrated target (003 Sec. IV-D). "
                   "Definitions: docs/texture.md, 'Fidelity metrics'.")
    head, rows = _fidelity_rows(results.grid)
    page.table(head, rows)
    results = results.renders
    page.heading("Low band: does the display add the friction the law asks for?")
    page.figure(_law_figure(results), out, "figures/friction_law.png", "mean added friction vs speed", dpi=100)
    rows = []
    for name, runs in results.items():
        for r in runs:
            s = r.summary()
            v, law_mean, sim_mean = _means(r)
            f, p, e = render_spectrum(r)
            dev = "n/a"
            if e is not None and f.size:
                top = min(500.0, 0.25 * (r.texture_rate or r.control_rate))
                _, d = spectral_deviation_db(f, p, e, 3.5, top)
                dev = f"{np.max(np.abs(d)):.2f} dB (3.5–{top:g} Hz)"
            rows.append([name, s["method"], f"{v * 1e3:.0f}", f"{r.texture_rate or '-'}",
                         f"{law_mean:.4f}", f"{sim_mean:.4f}", f"{100 * (sim_mean / law_mean - 1):+.2f} %",
                         dev, f"{s['max_abs_voltage']:.1f}", f"{s['clipped_fraction']:.1%}", f"{s['saturated_fraction']:.1%}"])
    page.table(["material", "method", "speed mm/s", "texture rate Hz", "G·law N", "simulated N", "error",
                "spectrum max dev (1/3 oct)", "max |V|", "clipped", "saturated"], rows)
    for name, runs in results.items():
        page.heading(name)
        spec = runs[0]
        bank = spec.texture_model
        tex = "friction-only (no real recording to fit a texture from)" if bank is None else \
            f"texture: {bank.quantity} AR({bank.max_order}) fitted at {spec.texture_rate} Hz, rendered at {spec.control_rate} Hz"
        note = next(iter(load_material(name).spec.notes), None)
        if note:
            tex += f". {note}"
        page.paragraph(tex, cls="note")
        page.figure(_speed_figure(name, runs), out, f"figures/{name}.png", f"{name} renders", dpi=100)
    return page.write(out / "report.html")
