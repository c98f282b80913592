"""Compare material models before testing them on people: friction-law curves, texture spectra
and drive-voltage histograms on the simulated display, side by side.

For each material (built-in name, fitted material file, or HaTT model file):

* friction law: the low-frequency coefficient mu(fn, v) over speed at a fixed load and the
  friction force mu fn over load at a fixed speed (quasi-static law if present, else Coulomb);
* texture spectrum: Welch PSD of the friction the simulated display adds while the material is
  rendered on back-and-forth strokes (``speed``, ``load``) with its default drive law;
* voltage histogram: the drive magnitude (after the safety stage) during that render.

Computing and plotting are separate: :func:`compare_materials` returns a
:class:`MaterialComparison`; ``.plot()`` draws the three panels, ``.rows()`` gives the table.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable

__all__ = ["MaterialProfile", "MaterialComparison", "compare_materials"]


@dataclass(frozen=True)
class MaterialProfile:
    """One material's curves (SI).

    speeds (s,) m/s and mu_speed (s,) at ``load``; loads (l,) N and force_load (l,) N at
    ``speed``; freqs (f,) Hz and psd (f,) N^2/Hz of the added friction; v_edges (b+1,) V and
    v_hist (b,) fraction of touching drive samples; summary: the render summary dict.
    """

    name: str
    method: str
    law: str
    texture: str
    speeds: np.ndarray
    mu_speed: np.ndarray
    loads: np.ndarray
    force_load: np.ndarray
    freqs: np.ndarray
    psd: np.ndarray
    v_edges: np.ndarray
    v_hist: np.ndarray
    v_mean: float
    v_p95: float
    v_max: float
    summary: dict


@dataclass(frozen=True)
class MaterialComparison(Result):
    """Profiles of the compared materials plus the scan they were rendered on."""

    profiles: tuple[MaterialProfile, ...]
    speed: float
    load: float
    duration: float

    def rows(self) -> list[list]:
        return [[p.name, p.method, p.law, p.texture, f"{np.interp(self.speed, p.speeds, p.mu_speed):.3f}",
                 f"{p.v_mean:.1f}", f"{p.v_p95:.1f}", f"{p.v_max:.1f}"] for p in self.profiles]

    header = ["material", "drive law", "friction law", "texture", "mu at scan", "V mean", "V p95", "V max"]

    panels = 4

    def summary(self) -> dict:
        return jsonable({"speed": self.speed, "load": self.load, "duration": self.duration,
                         "materials": [{"name": p.name, "method": p.method, "law": p.law, "texture": p.texture,
                                        "mu_at_scan": np.interp(self.speed, p.speeds, p.mu_speed), "v_mean": p.v_mean,
                                        "v_p95": p.v_p95, "v_max": p.v_max} for p in self.profiles]})

    def plot(self, ax=None):
        """Friction over speed and load, spectra, drive voltage histograms (4 panels)."""
        from surfhap.report.lab_figures import plot_comparison

        return plot_comparison(self, ax)


def compare_materials(refs: Sequence[str], *, speed: float = 0.1, load: float = 0.5, duration: float = 4.0,
                      seed: int = 0, v_max: float = 250.0) -> MaterialComparison:
    """Profile each material in ``refs`` (names or files) on the simulated display."""
    from scipy.signal import welch

    from surfhap.exchange.materials import load_material
    from surfhap.models.trajectory import strokes
    from surfhap.render.chain import ChainConfig
    from surfhap.render.drive import DriveParams, make_drive_law
    from surfhap.runtime.offline import render
    from surfhap.render.safety import SafetyLimits

    if not refs:
        raise ConfigError("give at least one material", field="materials")
    traj = strokes(speed, load, duration)
    speeds = np.linspace(0.005, 0.25, 60)
    loads = np.linspace(0.05, 2.0, 60)
    edges = np.linspace(0.0, v_max, 51)
    out = []
    for ref in refs:
        mat = load_material(ref)
        low = make_drive_law("friction-only", mat, DriveParams(alpha=1.0))  # mu_low(fn, v) fn, whatever alpha
        mu_v = low.friction_law.coefficient(np.full(speeds.size, load), speeds)
        f_l = low.low_force(speed, loads)
        res = render(mat, traj, ChainConfig(seed=seed, limits=SafetyLimits(v_max=v_max)))
        added = res.added_friction
        touching = res.load > 0
        x = added[touching] - np.mean(added[touching])
        nper = int(min(x.size, 2 ** int(np.log2(max(res.control_rate, 256)))))
        freqs, psd = welch(x, fs=res.control_rate, nperseg=nper)
        v = np.abs(res.drive)
        v_on = v[v > 0] if np.any(v > 0) else v
        hist, _ = np.histogram(v_on, bins=edges)
        hist = hist / max(1, v_on.size)
        name = mat.name if ref == mat.name else f"{mat.name} ({Path(ref).name})"  # a file: said, beside built-ins
        q = mat.quasi_static
        law = (f"Coulomb mu0={mat.coulomb.mu0:.3g}" if q is None else
               f"quasi-static a={q.a:.3g} b={q.b:.3g} c={q.c:.3g} d={q.d:.3g} q={q.q:.3g}")
        out.append(MaterialProfile(name, res.method, law, mat.texture_text(), speeds, mu_v, loads, f_l,
                                   freqs, psd, edges, hist, float(np.mean(v_on)), float(np.percentile(v_on, 95)),
                                   float(np.max(v)), res.summary()))
    return MaterialComparison(tuple(out), speed, load, duration)
