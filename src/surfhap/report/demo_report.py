"""The demo: every built-in material at three scan speeds on the simulated display, as a report.

``run_demo`` computes (a list of RenderResult); ``write_demo_report`` writes figures and
``report.html``. The CLI command ``surfhap demo`` wires them with a progress bar.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
from matplotlib.figure import Figure

from surfhap.report.figures import render_spectrum
from surfhap.report.html import Page
from surfhap.signal.bands import spectral_deviation_db

__all__ = ["DemoSettings", "run_demo", "write_demo_report", "DEMO_SPEEDS"]

DEMO_SPEEDS = (0.05, 0.10, 0.15)  # m/s: three of the reference velocities of Otake et al. 2022


@dataclass(frozen=True)
class DemoSettings:
    """speeds (m/s), load (N: within the 0.26-0.96 N participants used, Otake et al. 2022), seconds per render."""

    speeds: tuple[float, ...] = DEMO_SPEEDS
    load: float = 0.3
    duration: float = 10.0
    seed: int = 0


def run_demo(settings: DemoSettings = DemoSettings(), progress: Callable[[float], None] | None = None):
    """Render every built-in material at each speed; returns {material: [RenderResult, ...]}."""
    from surfhap.exchange.materials import builtin_names, load_material
    from surfhap.render.chain import ChainConfig
    from surfhap.render.offline import render
    from surfhap.sim.trajectory import constant_scan

    names = builtin_names()
    results = {}
    total = len(names) * len(settings.speeds)
    done = 0
    for name in names:
        mat = load_material(name)
        results[name] = []
        for speed in settings.speeds:
            traj = constant_scan(speed, settings.load, settings.duration)
            results[name].append(render(mat, traj, ChainConfig(seed=settings.seed)))
            done += 1
            if progress is not None:
                progress(done / total)
    return results


def _speed_figure(name: str, runs) -> Figure:
    fig = Figure(figsize=(11, 3.6), layout="constrained")
    a, b, c = fig.subplots(1, 3)
    for r in runs:
        v = float(np.median(r.speed[r.load > 0]))
        lab = f"{v * 1e3:.0f} mm/s"
        sel = r.t >= r.t[-1] - 0.5
        a.plot(r.t[sel], r.added_friction[sel], lw=0.7, label=lab)
        if r.texture_model is None:
            continue_spectrum = False
        else:
            f, p, e = render_spectrum(r)
            band = (f >= 3.5) & (f <= 0.4 * (r.texture_rate or r.model_rate))
            continue_spectrum = bool(band.any())
        if continue_spectrum:
            line, = b.loglog(f[band], p[band], lw=0.7, label=lab)
            if e is not None:
                b.loglog(f[band], e[band], lw=1.3, ls="--", color=line.get_color())
        sel2 = (r.t_drive >= 1.0) & (r.t_drive < 1.01)
        c.plot((r.t_drive[sel2] - 1.0) * 1e3, r.drive[sel2], lw=0.7, label=lab)
    fig.suptitle(name)
    a.set(title="added friction, last 0.5 s", xlabel="time (s)", ylabel="N")
    b.set(title="high band: simulated (solid) vs model (dashed)", xlabel="Hz", ylabel="N²/Hz")
    if runs[0].texture_model is None:
        b.text(0.5, 0.5, "friction-only:\nno texture to compare", ha="center", va="center", transform=b.transAxes)
        b.set_xticks([])
        b.set_yticks([])
    elif len(getattr(runs[0].texture_model, "models", ())) == 1:
        b.set_title("high band (one speed-independent model:\nthe speeds overlap)")
    c.set(title="drive after safety, 10 ms", xlabel="ms", ylabel="V")
    for ax in (a, b, c):
        if ax.lines:
            ax.legend(fontsize=7)
    return fig


def _law_figure(results) -> Figure:
    fig = Figure(figsize=(7, 4.2), layout="constrained")
    ax = fig.subplots()
    for i, (name, runs) in enumerate(results.items()):
        v = [float(np.median(r.speed[r.load > 0])) for r in runs]
        sim = [float(np.mean(r.added_friction[r.t > 0.5])) for r in runs]
        law = [float(np.mean((r.mu_low * r.load)[r.t > 0.5])) for r in runs]
        ax.plot(np.array(v) * 1e3, law, "-", color=f"C{i}", lw=1)
        ax.plot(np.array(v) * 1e3, sim, "o", color=f"C{i}", label=name)
    ax.set(xlabel="scan speed (mm/s)", ylabel="mean added friction (N)",
           title="simulated display (dots) vs friction law mu_low(fn, v)·fn (lines)")
    ax.legend(fontsize=8)
    return fig


def write_demo_report(results, out_dir: str | Path, settings: DemoSettings = DemoSettings()) -> Path:
    """Write one figure per material, a validation figure and ``report.html``; returns its path."""
    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    page = Page("surfhap demo: built-in materials on the simulated electrostatic display")
    page.paragraph(f"Each material is rendered by its default method along a straight scan at "
                   f"{', '.join(f'{s * 1e3:g}' for s in settings.speeds)} mm/s under a {settings.load:g} N load for "
                   f"{settings.duration:g} s, through the safety stage (250 V limit) onto the simulated display "
                   f"(mu_panel and k of eq. 1 are documented defaults, not measurements).")
    law = _law_figure(results)
    law.savefig(out / "figures" / "friction_law.png", dpi=100)
    page.heading("Low band: does the display add the friction the law asks for?")
    page.image("figures/friction_law.png", "mean added friction vs speed")
    rows = []
    for name, runs in results.items():
        for r in runs:
            s = r.summary()
            warm = r.t > 0.5
            law_mean = float(np.mean((r.mu_low * r.load)[warm]))
            sim_mean = float(np.mean(r.added_friction[warm]))
            f, p, e = render_spectrum(r)
            dev = "n/a"
            if e is not None and f.size:
                top = min(500.0, 0.25 * (r.texture_rate or r.model_rate))
                _, d = spectral_deviation_db(f, p, e, 3.5, top)
                dev = f"{np.max(np.abs(d)):.2f} dB (3.5–{top:g} Hz)"
            rows.append([name, s["method"], f"{np.median(r.speed[r.load > 0]) * 1e3:.0f}", f"{r.texture_rate or '-'}",
                         f"{law_mean:.4f}", f"{sim_mean:.4f}", f"{100 * (sim_mean / law_mean - 1):+.2f} %",
                         dev, f"{s['max_abs_voltage']:.1f}", f"{s['clipped_fraction']:.1%}", f"{s['saturated_fraction']:.1%}"])
    page.table(["material", "method", "speed mm/s", "texture rate Hz", "law N", "simulated N", "error",
                "spectrum max dev (1/3 oct)", "max |V|", "clipped", "saturated"], rows)
    for name, runs in results.items():
        fig = _speed_figure(name, runs)
        fn = f"figures/{name}.png"
        fig.savefig(out / fn, dpi=100)
        page.heading(name)
        spec = runs[0]
        bank = spec.texture_model
        tex = "friction-only (no real recording to fit a texture from)" if bank is None else \
            f"texture: {bank.quantity} AR({bank.max_order}) fitted at {spec.texture_rate} Hz, rendered at {spec.model_rate} Hz"
        page.paragraph(tex, cls="note")
        page.image(fn, f"{name} renders")
    path = out / "report.html"
    path.write_text(page.html(), encoding="utf-8")
    return path
