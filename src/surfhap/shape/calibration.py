"""Force range of a mesh by simulated scans (Kim et al. 2017, Sec. 4.2).

The range [Fsq_min, Fsq_max] that eq. 9 maps onto the intensity range depends on the object
and on how it is scanned. As in the paper, surfhap scans the object with a virtual finger in
many directions and at many speeds, collects the signed-square-root forces Fsq of every pair
of consecutive hit points (eq. 3-8), and takes ``(mean - 2 sd, mean + 2 sd)``. Percentiles
(``method="percentile"``) are the alternative for skewed distributions ("there can also be
good alternatives depending on the distribution of Fsq").

Scan plan (documented choices): ``directions`` headings evenly spaced all around (36: every
10 deg), ``speeds`` evenly spaced over 2-20 cm/s (a usual hand speed range; the paper's
tribometer ran at 6.5 cm/s), the touch rate of the paper's apps (60 Hz, Sec. 5.1.3; the
panel samples up to ~100 Hz, Sec. 2.2), and for each heading ``lines`` parallel scan lines
evenly spread across the disc that circumscribes the mesh's xy extent. Only pairs with both
hits on the mesh count. When a plan would take more than ``max_samples`` touch samples
(huge meshes at SI scale), fewer parallel lines are used and the reduction is recorded.
"""

from __future__ import annotations

from dataclasses import asdict, field
from typing import Annotated, Literal

import numba
import numpy as np
from pydantic import Field, FiniteFloat, model_validator

from surfhap.checked import checked_dataclass
from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable
from surfhap.shape.gradient import FZ_DEFAULT, gradient_step
from surfhap.shape.raycast import hit_one
from surfhap.shape.topsurface import TopSurface

__all__ = ["ScanPlan", "ShapeCalibration", "calibrate", "scan_lines", "METHODS"]

METHODS = ("sd", "percentile")


@checked_dataclass
class ScanPlan:
    """Straight scans of a calibration run (SI).

    directions  : number of headings, evenly spaced over 360 deg.
    speeds      : m/s, scan speeds.
    sensor_rate : Hz, touch sampling rate (60-100 Hz on the paper's tablet).
    lines       : parallel scan lines per heading.
    max_samples : upper bound on the touch samples of the whole plan.
    """

    directions: Annotated[int, Field(ge=1, le=3600)] = 36
    speeds: Annotated[tuple[Annotated[float, Field(gt=0, le=2.0)], ...], Field(min_length=1)] = (0.02, 0.065, 0.11, 0.155, 0.20)
    sensor_rate: Annotated[float, Field(ge=10, le=10_000)] = 60.0
    lines: Annotated[int, Field(ge=1, le=10_000)] = 16
    max_samples: Annotated[int, Field(ge=1000)] = 3_000_000

    @classmethod
    def evenly(cls, directions: int = 36, n_speeds: int = 5, v_min: float = 0.02, v_max: float = 0.20,
               **kw) -> "ScanPlan":
        """``n_speeds`` speeds evenly spaced over [v_min, v_max] m/s."""
        if not (isinstance(n_speeds, (int, np.integer)) and n_speeds >= 1):
            raise ConfigError("must be >= 1", field="n_speeds")
        speeds = (v_min,) if n_speeds == 1 else tuple(np.linspace(v_min, v_max, n_speeds))
        return cls(directions=directions, speeds=speeds, **kw)


@checked_dataclass
class ShapeCalibration(Result):
    """The Fsq range of one mesh (units: sqrt(N)) and how it was measured."""

    fmin: FiniteFloat
    fmax: FiniteFloat
    method: Literal["sd", "percentile", "manual"] = "sd"
    mean: float = 0.0
    sd: float = 0.0
    k: float = 2.0
    percentiles: tuple[float, float] = (2.5, 97.5)
    n_samples: int = 0
    fz: float = FZ_DEFAULT
    theta_min_deg: float | None = None
    mesh: str = ""
    plan: dict = field(default_factory=dict)
    hist_edges: tuple[float, ...] = ()
    hist_counts: tuple[int, ...] = ()

    @model_validator(mode="after")
    def _a_range(self):
        if not self.fmin < self.fmax:
            raise ValueError(f"need fmin < fmax, got ({self.fmin}, {self.fmax})")
        return self

    @classmethod
    def manual(cls, fmin: float, fmax: float, **kw) -> "ShapeCalibration":
        """A range given by hand, e.g. (-1, 1) as in the formative study (Sec. 4.2)."""
        return cls(float(fmin), float(fmax), method="manual", **kw)

    def summary(self) -> dict:
        return jsonable({"mesh": self.mesh, "method": self.method, "fmin": self.fmin, "fmax": self.fmax,
                         "n_samples": self.n_samples})

    def to_dict(self) -> dict:
        """Every field (what :meth:`from_dict` reads back) and the units."""
        return jsonable({**asdict(self), "units": "fmin/fmax/mean/sd in sqrt(N) (signed square root of the "
                                                  "lateral force, Kim et al. eq. 8)"})

    @classmethod
    def from_dict(cls, d: dict) -> "ShapeCalibration":
        return cls(**{k: v for k, v in d.items() if k in cls.__dataclass_fields__})  # lists become tuples

    def plot(self, ax=None):
        """Histogram of the scanned Fsq with the chosen range (matplotlib Figure)."""
        from surfhap.report.shape_figures import plot_calibration

        return plot_calibration(self, ax)


@numba.njit(cache=True, nogil=True)
def _scan_kernel(starts, dirs, steps, counts, fz, verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny,
                 start, items, out):
    # every on-mesh pair of consecutive samples of every line, through the one eq. 3-9 kernel
    m = 0
    for li in range(starts.shape[0]):
        sx = starts[li, 0]
        sy = starts[li, 1]
        dx = dirs[li, 0] * steps[li]
        dy = dirs[li, 1] * steps[li]
        px = np.nan
        py = np.nan
        pz = np.nan
        pf = 0.0
        for k in range(counts[li]):
            x = sx + k * dx
            y = sy + k * dy
            z, f = hit_one(x, y, verts, faces, esign, zmax, x0, y0, inv_cw, inv_ch, nx, ny, start, items)
            if f < 0:
                z = np.nan
            force, fsq, _, moved = gradient_step(x, y, z, px, py, pz, pf, fz, -1.0, 1.0)
            if moved:
                out[m] = fsq
                m += 1
            px = x
            py = y
            pz = z
            pf = force
    return m


def scan_lines(surface: TopSurface, plan: ScanPlan):
    """The scan lines of ``plan`` over ``surface``.

    Returns ``(starts (L, 2), dirs (L, 2), steps (L,), counts (L,) int, lines_used)``: start
    point, unit heading, distance between touch samples (speed / rate) and number of samples
    of each line.
    """
    lo, hi = surface.bounds
    c = (lo[:2] + hi[:2]) / 2.0
    radius = 0.5 * float(np.hypot(*(hi[:2] - lo[:2])))
    radius = radius if radius > 0 else 1.0
    ang = 2.0 * np.pi * np.arange(plan.directions) / plan.directions
    speeds = np.asarray(plan.speeds)
    steps_v = speeds / plan.sensor_rate
    per_line = np.floor(2.0 * radius / steps_v).astype(np.int64) + 1
    planned = int(plan.directions * plan.lines * per_line.sum())
    lines = plan.lines
    if planned > plan.max_samples:
        lines = max(1, int(plan.lines * plan.max_samples / planned))
    offs = radius * (-1.0 + (2.0 * np.arange(lines) + 1.0) / lines)
    d = np.column_stack([np.cos(ang), np.sin(ang)])
    p = np.column_stack([-np.sin(ang), np.cos(ang)])
    # (direction, line, speed) grid
    st = (c + offs[None, :, None] * p[:, None, :] - radius * d[:, None, :]).reshape(-1, 2)
    per_speed, reps = speeds.size, plan.directions * lines
    return (np.repeat(st, per_speed, axis=0), np.repeat(d, lines * per_speed, axis=0), np.tile(steps_v, reps),
            np.tile(per_line, reps), lines)


def scan_fsq(surface: TopSurface, plan: ScanPlan | None = None, fz: float = FZ_DEFAULT) -> tuple[np.ndarray, int]:
    """Fsq (m,) float of every on-mesh pair of consecutive samples of the plan, and the
    number of parallel lines used per heading."""
    plan = plan or ScanPlan()
    starts, dirs, steps, counts, lines = scan_lines(surface, plan)
    out = np.empty(int(counts.sum()))
    m = _scan_kernel(starts, dirs, steps, counts, float(fz), *surface._args, out)
    return out[:m], lines


def calibrate(surface: TopSurface, plan: ScanPlan | None = None, *, method: str = "sd", k: float = 2.0,
              percentiles: tuple[float, float] = (2.5, 97.5), fz: float = FZ_DEFAULT) -> ShapeCalibration:
    """Scan ``surface`` as ``plan`` says and return the Fsq range (Sec. 4.2).

    method "sd": (mean - k sd, mean + k sd) with k = 2 (the paper's choice);
    method "percentile": the given lower and upper percentiles of Fsq.
    A flat object (all Fsq equal) gets a range of +-1e-9 around that value.
    """
    if method not in METHODS:
        raise ConfigError(f"unknown method {method!r} (choose from {', '.join(METHODS)})", field="method")
    if not (np.isfinite(k) and k > 0):
        raise ConfigError("must be > 0", field="k")
    lo_p, hi_p = (float(v) for v in percentiles)
    if not 0 <= lo_p < hi_p <= 100:
        raise ConfigError("need 0 <= lower < upper <= 100", field="percentiles")
    if not (np.isfinite(fz) and fz > 0):
        raise ConfigError("must be > 0 N", field="fz")
    plan = plan or ScanPlan()
    fsq, lines = scan_fsq(surface, plan, fz)
    if fsq.size < 2:
        raise ConfigError("the calibration scans hit the mesh fewer than twice; is the mesh tiny or the "
                          "sensor rate too low for it?", source=surface.source or surface.name)
    mean = float(fsq.mean())
    sd = float(fsq.std())
    if method == "sd":
        fmin, fmax = mean - k * sd, mean + k * sd
    else:
        fmin, fmax = (float(v) for v in np.percentile(fsq, [lo_p, hi_p]))
    if not fmax - fmin > 1e-9:
        mid = 0.5 * (fmin + fmax)
        fmin, fmax = mid - 1e-9, mid + 1e-9
    counts, edges = np.histogram(fsq, bins=60)
    plan_d = {"directions": plan.directions, "speeds_m_s": list(plan.speeds), "sensor_rate_hz": plan.sensor_rate,
              "lines_per_direction": lines, "lines_requested": plan.lines}
    return ShapeCalibration(
        fmin=float(fmin), fmax=float(fmax), method=method, mean=mean, sd=sd, k=float(k),
        percentiles=(lo_p, hi_p), n_samples=int(fsq.size), fz=float(fz), theta_min_deg=float(surface.theta_min),
        mesh=surface.source or surface.name, plan=plan_d,
        hist_edges=tuple(float(e) for e in edges), hist_counts=tuple(int(c) for c in counts),
    )
