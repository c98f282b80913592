"""Fidelity metrics of one render on the simulated display (the targets of docs/texture.md).

For a constant scan (one load fn, one speed v) rendered at rendering gain G
(``RenderResult.rendering_gain``), with the added friction ``f_add = friction_sim - mu_panel fn``
(N, control rate) and the band split at ``cutoff`` (3.5 Hz, 003 Sec. II; :class:`~surfhap.signal.bands.BandSplit`):

saturated_fraction
    drive samples the safety stage clamped to v_max, over all drive samples.
low_band_error
    ``mean(lowpass(f_add)) / (G mean(mu_low fn)) - 1`` over the steady part (after ``warmup``
    s): how far the display's low band is from the friction law (``mu_p(fn, v) fn``, or
    ``mu0 fn`` for otake2021, ``mu0 fn_c`` for zhao: the drive law's ``LowBand``) times the
    planned gain.
texture_correlation
    Pearson r between ``highpass(f_add)`` and ``highpass(G (target - mu_low fn))``, the textural
    force the law asked for, shifted by the chain's and the display's delays: does the
    simulated friction follow the texture? (None without a texture.)
voltage_ratio
    ``sqrt(sd(highpass(f_add)) / mean(lowpass(f_add)))``: the texture:friction voltage ratio
    ``sqrt(beta sd(mu_t) / mu_low)`` of :mod:`surfhap.models.texture_calibration`, measured on
    the simulated friction (10:3 is 0.3).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from surfhap.results import Result, jsonable
from surfhap.signal.bands import BandSplit

__all__ = ["FidelityMetrics", "fidelity_metrics"]


@dataclass(frozen=True)
class FidelityMetrics(Result):
    """See the module docstring; ``load`` N and ``speed`` m/s are the medians while touching."""

    material: str
    method: str
    load: float
    speed: float
    rendering_gain: float
    saturated_fraction: float
    clipped_fraction: float
    low_band_error: float
    texture_correlation: float | None
    voltage_ratio: float
    target_voltage_ratio: float | None

    @property
    def ratio_error(self) -> float | None:
        """voltage_ratio / target - 1, or None without a target."""
        if not self.target_voltage_ratio:
            return None
        return self.voltage_ratio / self.target_voltage_ratio - 1.0

    def summary(self) -> dict:
        return jsonable({**asdict(self), "ratio_error": self.ratio_error})

    def plot(self, ax=None):
        """The metrics as bars (see :mod:`surfhap.report.figures`)."""
        from surfhap.report.figures import plot_fidelity

        return plot_fidelity(self, ax)


def fidelity_metrics(result, cutoff: float = 3.5, warmup: float = 0.5, target_voltage_ratio: float | None = None) -> FidelityMetrics:
    """Metrics of a RenderResult of a constant scan; ``target_voltage_ratio`` defaults to the
    material file's calibration when the caller passes the material's value."""
    r = result
    rate = float(r.control_rate)
    touching = r.load > 0
    fn = float(np.median(r.load[touching])) if np.any(touching) else 0.0
    v = float(np.median(r.speed[touching])) if np.any(touching) else 0.0
    g = r.rendering_gain
    f_add = r.added_friction
    split = BandSplit(cutoff=cutoff)
    lo, hi = split.split(f_add, rate)
    steady = (r.t >= warmup) & touching
    law_force = r.low_band.force(r.load, r.mu_low)  # the drive law's low band (Zhao: its constant load)
    law = g * float(np.mean(law_force[steady]))
    lo_mean = float(np.mean(lo[steady]))
    low_err = lo_mean / law - 1.0 if law > 0 else float("nan")
    ratio = float(np.sqrt(max(float(np.std(hi[steady])), 0.0) / lo_mean)) if lo_mean > 0 else 0.0
    corr = None
    tex_force = g * (r.target - law_force)
    if r.texture_model is not None and r.method not in ("friction-only", "square") and np.any(tex_force != 0):
        tex_hi = split.high(tex_force, rate)
        d = int(round((r.latency + r.display_latency) * rate))
        a = hi[d:]
        b = tex_hi[: tex_hi.size - d]
        sel = steady[: b.size] & steady[d:]
        if np.count_nonzero(sel) > 10 and np.std(b[sel]) > 0 and np.std(a[sel]) > 0:
            corr = float(np.corrcoef(a[sel], b[sel])[0, 1])
    s = r.safety
    return FidelityMetrics(
        material=r.material, method=r.method, load=fn, speed=v, rendering_gain=g,
        saturated_fraction=s.clamped / s.samples if s.samples else 0.0, clipped_fraction=r.clipped_fraction,
        low_band_error=low_err, texture_correlation=corr, voltage_ratio=ratio, target_voltage_ratio=target_voltage_ratio,
    )
