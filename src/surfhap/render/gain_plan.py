"""Gain planning: choose alpha so a material renders without saturating over an operating range.

The papers set their gains per material (and per participant) so that the stimuli stayed under
250 V for the loads people use (Otake et al. 2022, Sec. IV-D; Zhao et al. scale the voltage
down, Sec. 2.2). :func:`plan_gains` does this explicitly: over a grid of loads and speeds (by
default 0.1-1.0 N and 0.02-0.3 m/s, which holds the 0.26-0.96 N and 50-150 mm/s of 003
Sec. II), it computes the target force of the drive law at the 99.9th percentile of the
texture, ``F_999(fn, v) = F_low(fn, v) + z_999 * sd(F_tex(fn, v))`` (a Gaussian AR texture;
z_999 = 3.09), and picks

    alpha = min(alpha_calibrated, fill * v_max / sqrt(max F_999), alpha_rise)

where ``alpha_calibrated = 1/sqrt(mu_panel k)`` renders the law at gain 1, ``fill`` (0.95) leaves
5 % margin for the resampler's overshoot, and ``alpha_rise`` keeps the 99.9th percentile slope of
the textured envelope (in the texture's troughs, 2 sd below the law) under the safety stage's
rise limit. The friction then renders at the
**rendering gain** ``G = (alpha / alpha_calibrated)^2``: the display adds ``G`` times the law's
force, the same fraction at every load and speed, so the law's shape over load and speed is kept.
Onsets (touch-down, the square baseline's edges) are always shaped by the rise limit; that is
the safety stage's job, not saturation.

The result is a :class:`GainPlan` with named fields and ``.plot()``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated

import numpy as np
from pydantic import Field, field_validator
from scipy.special import ndtri

from surfhap.checked import checked_dataclass
from surfhap.errors import ConfigError
from surfhap.models.material import Material
from surfhap.models.panel import DisplayModel
from surfhap.render.drive import DriveParams, Square, make_drive_law, rendering_gain
from surfhap.render.safety import SafetyLimits
from surfhap.results import Result, jsonable

__all__ = ["OperatingRange", "GainPlan", "plan_gains", "PLAN_PERCENTILE", "PLAN_FILL"]

PLAN_PERCENTILE = 99.9
PLAN_FILL = 0.95
_DEFAULTS = DriveParams(alpha=1.0)  # the drive laws' defaults (beta, m_eff, Zhao's constant load ...)


@checked_dataclass
class OperatingRange:
    """Loads (N) and speeds (m/s) a rendering must serve, as (low, high) pairs, and grid sizes."""

    loads: tuple[Annotated[float, Field(gt=0, le=50.0)], Annotated[float, Field(gt=0, le=50.0)]] = (0.1, 1.0)
    speeds: tuple[Annotated[float, Field(ge=0, le=10.0)], Annotated[float, Field(ge=0, le=10.0)]] = (0.02, 0.3)
    n_loads: Annotated[int, Field(ge=2)] = 19
    n_speeds: Annotated[int, Field(ge=2)] = 15

    @field_validator("loads", "speeds")
    @classmethod
    def _low_before_high(cls, pair):
        if pair[0] > pair[1]:
            raise ValueError(f"needs low <= high, got {pair[0]:g},{pair[1]:g}")
        return pair

    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        """(n_loads,) N and (n_speeds,) m/s, both including the ends."""
        return np.linspace(*self.loads, self.n_loads), np.linspace(*self.speeds, self.n_speeds)


@dataclass(frozen=True)
class GainPlan(Result):
    """A gain plan (SI).

    method, alpha (V/sqrt(N)), alpha_calibrated, rendering_gain = (alpha/alpha_calibrated)^2,
    texture_gain (multiplier on the material's texture), beta, binding ("calibration", "v_max"
    or "rise"), v_max (V), operating_range;
    loads (L,) N; friction_low_n, friction_high_n (L,): smallest and largest added friction over
    the speeds at each load, at the rendering gain (the renderable friction range);
    peak_voltage (L,) V: largest 99.9th-percentile voltage over the speeds at each load;
    display_max_n: the force the display adds at v_max (mu_panel k v_max^2);
    headroom: v_max / max(peak_voltage) (>= 1 means no saturation over the range);
    square_amplitude (V) and square_reference (load N, speed m/s) for the square baseline.
    """

    method: str
    alpha: float
    alpha_calibrated: float
    rendering_gain: float
    texture_gain: float
    beta: float
    binding: str
    v_max: float
    operating_range: OperatingRange
    loads: np.ndarray = field(repr=False)
    friction_low_n: np.ndarray = field(repr=False)
    friction_high_n: np.ndarray = field(repr=False)
    peak_voltage: np.ndarray = field(repr=False)
    display_max_n: float = 0.0
    headroom: float = float("inf")
    percentile: float = PLAN_PERCENTILE
    square_amplitude: float | None = None
    square_reference: tuple[float, float] | None = None
    material: str = ""

    @property
    def headroom_db(self) -> float:
        """20 log10(headroom)."""
        return float(20 * np.log10(self.headroom)) if np.isfinite(self.headroom) and self.headroom > 0 else float("inf")

    panels = 2

    def summary(self) -> dict:
        return jsonable({"material": self.material, "method": self.method, "alpha_v_per_sqrt_n": self.alpha,
                         "rendering_gain": self.rendering_gain, "binding_constraint": self.binding,
                         "headroom_db": self.headroom_db})

    def to_dict(self) -> dict:
        """JSON-ready plan (used in summary.json and ``surfhap materials --show``)."""
        d = {
            "method": self.method, "alpha_v_per_sqrt_n": self.alpha, "alpha_calibrated_v_per_sqrt_n": self.alpha_calibrated,
            "rendering_gain": self.rendering_gain, "texture_gain": self.texture_gain, "beta": self.beta,
            "binding_constraint": self.binding, "v_max": self.v_max, "percentile": self.percentile,
            "load_range_n": list(self.operating_range.loads), "speed_range_m_per_s": list(self.operating_range.speeds),
            "renderable_friction_n": {"load_n": [float(x) for x in self.loads],
                                      "low": [float(x) for x in self.friction_low_n],
                                      "high": [float(x) for x in self.friction_high_n]},
            "peak_voltage_v": [float(x) for x in self.peak_voltage],
            "display_max_n": self.display_max_n,
            "headroom": self.headroom if np.isfinite(self.headroom) else None,
            "headroom_db": self.headroom_db if np.isfinite(self.headroom_db) else None,
        }
        if self.square_amplitude is not None:
            d["square_amplitude_v"] = self.square_amplitude
            d["square_reference"] = {"load_n": self.square_reference[0], "speed_m_per_s": self.square_reference[1]}
        return jsonable(d)

    def plot(self, ax=None):
        """Renderable friction range and peak voltage over load (matplotlib Figure, 2 panels)."""
        from surfhap.report.plan_figures import plot_gain_plans

        return plot_gain_plans([self], ax)


def plan_gains(material: Material, method: str, display: DisplayModel | None = None,
               operating_range: OperatingRange | None = None, limits: SafetyLimits | None = None, *,
               beta: float = _DEFAULTS.beta, texture_gain: float = _DEFAULTS.texture_gain,
               effective_mass: float = _DEFAULTS.effective_mass, constant_load: float | None = _DEFAULTS.constant_load,
               square_reference: tuple[float, float] = (_DEFAULTS.square_reference_load, _DEFAULTS.square_reference_speed),
               fill: float = PLAN_FILL, percentile: float = PLAN_PERCENTILE) -> GainPlan:
    """Plan alpha for ``material`` rendered by ``method`` (a resolved method name, not "auto").

    Pure function of its arguments; see the module docstring for the rule. The forces are the
    drive law's own (:meth:`~surfhap.render.drive.DriveLaw.low_force` and
    ``texture_force_per_unit``, which do not depend on alpha); the square baseline's on-level is
    ``2 mu_low(fn_ref, v_ref) fn_ref`` at ``square_reference`` = (fn_ref N, v_ref m/s).
    """
    display = display or DisplayModel()
    rng = operating_range or OperatingRange()
    limits = limits or SafetyLimits()
    if not 0 < fill <= 1:
        raise ConfigError("must be in (0, 1]", field="fill")
    law = make_drive_law(method, material, DriveParams(
        alpha=1.0, beta=beta, effective_mass=effective_mass, constant_load=constant_load, texture_gain=texture_gain,
        square_reference_load=square_reference[0], square_reference_speed=square_reference[1]))
    z = float(ndtri(percentile / 100.0))  # the standard normal quantile (norm.ppf without its generic checks)
    loads, speeds = rng.grid()
    fn, v = (a.ravel() for a in np.meshgrid(loads, speeds, indexing="ij"))  # (L*S,) grid points
    alpha_cal = float(display.calibrated_alpha)
    shape = (loads.size, speeds.size)
    f_low = law.low_force(v, fn).reshape(shape)
    sq_amp_force = None
    if isinstance(law, Square):
        sq_amp_force = law.on_force
        f_999 = np.full(shape, sq_amp_force)
        slope_999 = f_trough = np.zeros(shape)
    else:
        sd_x = sd_dx = np.zeros(fn.size)
        if law.uses_texture:
            # the texture's sd and slope sd at each grid point: the model the renderer would use there
            sd_x, sd_dx = material.texture.moments_at(v, fn)
        per_unit = law.texture_force_per_unit(v, fn)  # N per texture unit
        sd_tex = (per_unit * sd_x).reshape(shape)
        f_999 = f_low + z * sd_tex
        slope_999 = (z * per_unit * sd_dx).reshape(shape)  # 99.9th percentile |dF/dt|, N/s
        f_trough = np.maximum(f_low - 2.0 * sd_tex, 0.25 * f_low)  # N, a low force (2 sd below the law) where dV/dF is steep
    peak_f = float(np.max(f_999))
    candidates = {"calibration": alpha_cal}
    if peak_f > 0:
        candidates["v_max"] = fill * limits.v_max / np.sqrt(peak_f)
    # dV/dt = alpha dF/dt / (2 sqrt(F)) is steepest in the texture's troughs: bound it at a force
    # 2 sd below the law's (at least a quarter of it) by the rise rate
    with np.errstate(divide="ignore", invalid="ignore"):
        k_slope = np.where(f_trough > 0, slope_999 / (2.0 * np.sqrt(f_trough)), 0.0)
    if np.max(k_slope) > 0:
        candidates["rise"] = fill * limits.rise_rate / float(np.max(k_slope))
    binding = min(candidates, key=candidates.get)
    alpha = float(candidates[binding])
    gain = rendering_gain(alpha, alpha_cal)
    peak_v = alpha * np.sqrt(np.max(f_999, axis=1))
    return GainPlan(
        method=method, alpha=alpha, alpha_calibrated=alpha_cal, rendering_gain=float(gain), texture_gain=float(texture_gain),
        beta=float(beta), binding=binding, v_max=float(limits.v_max), operating_range=rng, loads=loads,
        friction_low_n=gain * np.min(f_low, axis=1), friction_high_n=gain * np.max(f_low, axis=1), peak_voltage=peak_v,
        display_max_n=float(display.mu_panel * display.k * limits.v_max ** 2),
        headroom=float(limits.v_max / np.max(peak_v)) if np.max(peak_v) > 0 else float("inf"), percentile=percentile,
        square_amplitude=None if sq_amp_force is None else float(alpha * np.sqrt(sq_amp_force)),
        square_reference=None if sq_amp_force is None else (float(square_reference[0]), float(square_reference[1])),
        material=material.name,
    )
