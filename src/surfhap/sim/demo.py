"""The demo run: every built-in material at three scan speeds and three loads on the simulated display.

``run_demo`` computes (renders, fidelity metrics and gain plans);
:func:`surfhap.report.demo_report.write_demo_report` writes figures and ``report.html``
from its result. The CLI command ``surfhap demo`` wires them with a progress bar.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

__all__ = ["DemoSettings", "DemoResults", "run_demo", "DEMO_SPEEDS", "DEMO_LOADS"]

DEMO_SPEEDS = (0.05, 0.10, 0.15)  # m/s: three of the reference velocities of Otake et al. 2022
DEMO_LOADS = (0.26, 0.5, 0.96)  # N: the ends and middle of the participants' mean loads (003 Sec. II)


@dataclass(frozen=True)
class DemoSettings:
    """speeds (m/s), loads (N, 003 Sec. II: 0.26-0.96 N), ``load`` (N) of the per-material figures,
    seconds per render, seed, display (DisplayModel or None for the documented assumptions)."""

    speeds: tuple[float, ...] = DEMO_SPEEDS
    loads: tuple[float, ...] = DEMO_LOADS
    load: float = 0.5
    duration: float = 10.0
    seed: int = 0
    display: object | None = None


@dataclass
class DemoResults:
    """renders {material: [RenderResult at ``settings.load``, one per speed]}; grid: list of
    (RenderResult, FidelityMetrics) over loads x speeds x materials; plans {material: GainPlan};
    the settings they were computed with."""

    renders: dict
    grid: list
    plans: dict
    settings: DemoSettings


def run_demo(settings: DemoSettings = DemoSettings(), progress: Callable[[float], None] | None = None) -> DemoResults:
    """Render every built-in material at each load and speed; returns :class:`DemoResults`."""
    from surfhap.exchange.materials import builtin_names, load_material
    from surfhap.models.panel import DisplayModel
    from surfhap.models.trajectory import constant_scan
    from surfhap.render.chain import ChainConfig
    from surfhap.render.fidelity import fidelity_metrics
    from surfhap.runtime.offline import render

    names = builtin_names()
    loads = tuple(dict.fromkeys((*settings.loads, settings.load)))
    renders, grid, plans = {}, [], {}
    total = len(names) * len(settings.speeds) * len(loads)
    done = 0
    display = settings.display or DisplayModel()
    for name in names:
        mat = load_material(name)
        cal = mat.spec.texture_calibration
        target = None if cal is None else cal.target_voltage_ratio
        renders[name] = []
        for i, load in enumerate(loads):
            for j, speed in enumerate(settings.speeds):
                # one noise seed per cell, so the table shows the spread over texture realisations
                cfg = ChainConfig(seed=settings.seed + 10 * i + j, display=display)
                r = render(mat, constant_scan(speed, load, settings.duration), cfg)
                plans[name] = r.plan
                if load == settings.load:
                    renders[name].append(r)
                if load in settings.loads:
                    grid.append((r, fidelity_metrics(r, target_voltage_ratio=target)))
                done += 1
                if progress is not None:
                    progress(done / total)
    return DemoResults(renders, grid, plans, settings)
