"""The demo report: figures and ``report.html`` from :func:`surfhap.sim.demo.run_demo`'s result.

Reads results only; the renders are computed in :mod:`surfhap.sim.demo`.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.axes import carrier_resolved, draw_drive, figure_axes, plain_log_ticks
from surfhap.report.figures import render_spectrum
from surfhap.report.html import Page
from surfhap.signal.bands import spectral_deviation_db

if TYPE_CHECKING:
    from surfhap.sim.demo import DemoResults

__all__ = ["write_demo_report", "plot_material_renders"]


_STYLES = ("-", "-.", ":")  # one line style per speed (colour alone fails in grey print; dashed is the model)
GAIN_NOTE = ("G = (alpha / alpha_calibrated)²: the share of the friction law's force the display adds, the same at "
             "every load and speed (1 = all of it); the gain plan lowers alpha so the texture's peaks stay under v_max")


def _demo_layout(fig):
    top = fig.add_gridspec(1, 3)
    drive = top[0, 2].subgridspec(3, 1, hspace=0.08)
    a, b, c0 = fig.add_subplot(top[0, 0]), fig.add_subplot(top[0, 1]), fig.add_subplot(drive[0])
    return [a, b, c0, fig.add_subplot(drive[1], sharex=c0), fig.add_subplot(drive[2], sharex=c0)]


def plot_material_renders(name: str, runs, load: float) -> Figure:
    """One material rendered at ``load`` N and several speeds (``runs``, one RenderResult per
    speed, up to 3): added friction, high-band spectrum vs the texture model, and the drive after
    safety, one small panel per speed (its envelope when the figure cannot show the carrier)."""
    fig, axs = figure_axes(None, 5, (11, 4.6), layout=_demo_layout)
    a, b, drive = axs[0], axs[1], axs[2:]
    r0 = runs[0]
    models = []
    for i, (r, d) in enumerate(zip(runs, drive)):
        style = dict(color=f"C{i}", ls=_STYLES[i % len(_STYLES)])
        lab = f"{float(np.median(r.speed[r.load > 0])) * 1e3:.0f} mm/s"
        sel = r.t >= r.t[-1] - 0.5
        a.plot(r.t[sel], r.added_friction[sel], lw=0.8, alpha=0.85, label=lab, **style)
        if r.texture_model is not None:
            f, p, e = render_spectrum(r)
            band = (f >= 3.5) & (f <= 0.4 * (r.texture_rate or r.control_rate))
            if band.any():
                b.loglog(f[band], p[band], lw=0.9, label=f"{lab} simulated", **style)
                if e is not None:
                    models.append((f[band], e[band], style["color"], lab))
        if carrier_resolved(r.drive_rate, r.carrier):
            sel2 = (r.t_drive >= 1.0) & (r.t_drive < 1.01)
        else:
            sel2 = r.t_drive >= r.t_drive[-1] - 0.5
        t0 = r.t_drive[sel2][0] if sel2.any() else 0.0
        draw_drive(d, (r.t_drive[sel2] - t0) * 1e3, r.drive[sel2], r.drive_rate, r.carrier, color=f"C{i}", label=lab)
        d.set_ylabel("V")
        top = float(np.max(np.abs(r.drive[sel2]))) if sel2.any() else 1.0
        d.set_ylim(-1.15 * top, 2.0 * top)  # room above the drive for its legend
        d.legend(fontsize=6, loc="upper right")
        if d is not drive[len(runs) - 1]:
            d.tick_params(labelbottom=False)
    for d in drive[len(runs):]:
        d.set_visible(False)
    if models and all(np.allclose(m[1], models[0][1], rtol=1e-9) for m in models):
        b.loglog(models[0][0], models[0][1], "k--", lw=1.4, label="AR model (the same at every speed)")
    else:  # thick and translucent: the models of nearby speeds lie within a few % of each other
        for f, e, c, lab in models:
            b.loglog(f, e, lw=3, alpha=0.35, color=c, label=f"{lab} AR model")
    fig.suptitle(f"{name} — {r0.method}, {load:g} N, G = {r0.rendering_gain:.2f} (of the law's friction)", fontsize=11)
    a.set(title="added friction, last 0.5 s", xlabel="time (s)", ylabel="added friction (N)")
    b.set(title="high band (≥ 3.5 Hz) vs texture model", xlabel="frequency (Hz)", ylabel="PSD (N²/Hz)")
    if b.get_xscale() == "log":
        plain_log_ticks(b.xaxis)
    if r0.texture_model is None:
        b.text(0.5, 0.5, "friction-only:\nno texture to compare", ha="center", va="center", transform=b.transAxes)
        b.set_xticks([])
        b.set_yticks([])
    span = "10 ms" if carrier_resolved(r0.drive_rate, r0.carrier) else "last 0.5 s"
    drive[0].set_title(f"drive after safety, {span}\n{r0.carrier:g} Hz carrier at {r0.drive_rate:g} Hz", fontsize=10)
    drive[len(runs) - 1].set_xlabel("time (ms)")
    for ax in (a, b):
        if ax.lines:
            ax.legend(fontsize=7)
    fig.supxlabel(textwrap.fill(GAIN_NOTE, 150), fontsize=8, color="0.3")
    return fig


def _means(r) -> tuple[float, float, float]:
    """(median touching speed m/s, mean of G mu_low fn N, mean simulated added friction N) after 0.5 s."""
    warm = r.t > 0.5
    return (float(np.median(r.speed[r.load > 0])), r.rendering_gain * float(np.mean((r.mu_low * r.load)[warm])),
            float(np.mean(r.added_friction[warm])))


def _law_figure(results, load: float) -> Figure:
    fig, (ax,) = figure_axes(None, 1, (7, 4.2))
    for i, (name, runs) in enumerate(results.items()):
        v, law, sim = np.array([_means(r) for r in runs]).T
        ax.plot(v * 1e3, law, "-", color=f"C{i}", lw=1)
        ax.plot(v * 1e3, sim, "o", color=f"C{i}", label=f"{name} simulated")
    ax.plot([], [], "k-", lw=1, label="G·mu_low(fn, v)·fn (line, per material)")
    ax.set(xlabel="scan speed (mm/s)", ylabel="mean added friction (N)",
           title=f"at {load:g} N: simulated display (dots) vs G·mu_low(fn, v)·fn (lines)")
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
    page.heading(f"Low band at {settings.load:g} N: does the display add the friction the law asks for?")
    page.figure(_law_figure(results, settings.load), out, "figures/friction_law.png", "mean added friction vs speed", dpi=100)
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
            rows.append([name, s["method"], f"{settings.load:g}", f"{v * 1e3:.0f}", f"{r.texture_rate or '-'}",
                         f"{law_mean:.4f}", f"{sim_mean:.4f}", f"{100 * (sim_mean / law_mean - 1):+.2f} %",
                         dev, f"{s['max_abs_voltage']:.1f}", f"{s['clipped_fraction']:.1%}", f"{s['saturated_fraction']:.1%}"])
    page.table(["material", "method", "load N", "speed mm/s", "texture rate Hz", "G·law N", "simulated N", "error",
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
        page.figure(plot_material_renders(name, runs, settings.load), out, f"figures/{name}.png",
                    f"{name} renders at {settings.load:g} N", dpi=100)
    return page.write(out / "report.html")
