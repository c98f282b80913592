"""The device curve: the lateral force a display adds over its drive (Kim et al. 2017 Sec. 2.2, Fig. 2c).

``F(u) = c0 + c1 u + c2 u^2`` (N), **ascending coefficients** ``(c0, c1, c2)`` (the order of
``numpy.polynomial``), over the drive ``u``: an ``"intensity"`` in [0, 1] or a ``"voltage"`` in
V, measured on ``[0, input_max]`` (``input_max`` None: 1 for an intensity, unbounded for a
voltage). The one definition: the shape renderer's grains, the display calibration
(:mod:`surfhap.lab.calibration`, which writes it) and the display file
(:mod:`surfhap.models.display`) all use this class.

:meth:`DeviceCurve.drive_for_force` inverts the curve: the smallest drive in ``[0, input_max]``
whose force reaches ``F`` (forces at or below ``F(0)`` give 0, forces above the curve's largest
value give the drive of that value), in closed form: the root
``u = 2 (F - c0) / (c1 + sqrt(c1^2 + 4 c2 (F - c0)))`` of the rising branch, which is the
inverse on the monotone branch for every quadratic that rises somewhere on its range.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable
from surfhap.signal.tribometer import fit_quadratic

__all__ = ["DeviceCurve"]


class DeviceCurve(BaseModel, Result):
    """Lateral force (N) over the drive: ``F(u) = c0 + c1 u + c2 u^2`` on ``[0, input_max]``.

    input        : "intensity" (0..1) or "voltage" (V).
    coefficients : (c0, c1, c2), ascending powers (N, N/unit, N/unit^2).
    input_max    : largest drive the curve holds for; None = 1 for an intensity, unbounded
                   for a voltage (the safety stage clamps).
    source       : where the curve comes from (a paper, a calibration, "square law").
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    input: Literal["intensity", "voltage"]
    coefficients: tuple[float, float, float]
    input_max: float | None = Field(default=None, gt=0)
    source: str = ""

    @model_validator(mode="after")
    def _rises(self) -> "DeviceCurve":
        if not self.max_force > self.coefficients[0]:
            raise ValueError("the force must increase with the drive somewhere on its range")
        return self

    @property
    def u_max(self) -> float:
        """Largest drive: ``input_max``, 1 for an intensity, inf for a voltage without one."""
        if self.input_max is not None:
            return float(self.input_max)
        return 1.0 if self.input == "intensity" else math.inf

    @property
    def max_force(self) -> float:
        """N, the largest force on ``[0, u_max]`` (inf for an unbounded rising curve)."""
        c0, c1, c2 = self.coefficients
        top = self.u_max
        cand = [c0]
        if math.isfinite(top):
            cand.append((c2 * top + c1) * top + c0)
        elif c2 > 0 or (c2 == 0 and c1 > 0):
            return math.inf
        if c2 < 0 and 0 < -c1 / (2 * c2) < top:
            cand.append(c0 - c1 * c1 / (4 * c2))
        return float(max(cand))

    def force(self, u: np.ndarray) -> np.ndarray:
        """F (n,) N at drive u (n,), clipped to ``[0, u_max]``."""
        c0, c1, c2 = self.coefficients
        x = np.clip(np.asarray(u, dtype=float), 0.0, self.u_max)
        return (c2 * x + c1) * x + c0

    def drive_for_force(self, force: np.ndarray) -> np.ndarray:
        """Drive (n,) for force (n,) N: the smallest u in ``[0, u_max]`` with ``F(u) >= min(force,
        max_force)``; 0 for forces at or below ``F(0)``; NaN stays NaN (see the module docstring)."""
        c0, c1, c2 = self.coefficients
        g = np.minimum(np.asarray(force, dtype=float), self.max_force) - c0
        with np.errstate(invalid="ignore", divide="ignore"):
            u = 2.0 * g / (c1 + np.sqrt(np.maximum(c1 * c1 + 4.0 * c2 * g, 0.0)))
        return np.clip(np.where(g <= 0.0, 0.0, u), 0.0, self.u_max)

    @classmethod
    def fit(cls, u: np.ndarray, force: np.ndarray, input: str = "intensity", input_max: float | None = None,
            source: str = "fit") -> "DeviceCurve":
        """Least-squares quadratic through (u (n,), force (n,) N) pairs at three or more distinct
        drives (:func:`surfhap.signal.tribometer.fit_quadratic`, the calibration's own fit)."""
        c = fit_quadratic(u, force).coefficients
        return cls.of(input, c, input_max, source)

    @classmethod
    def of(cls, input: str, coefficients, input_max: float | None = None, source: str = "") -> "DeviceCurve":
        """A curve from ascending coefficients; ConfigError(field="device") when it is not one."""
        try:
            return cls(input=input, coefficients=tuple(float(c) for c in coefficients), input_max=input_max,
                       source=source)
        except ValidationError as exc:
            raise ConfigError(exc.errors()[0]["msg"], field="device") from None

    @classmethod
    def from_tribometer(cls, recordings: dict, fs: float, source: str = "tribometer") -> "DeviceCurve":
        """Fit from tribometer recordings ``{intensity: force (n,) N}`` at ``fs`` Hz: each
        recording's vibratory amplitude (Sec. 2.2), then the quadratic fit (Fig. 2c)."""
        from surfhap.signal.tribometer import tribometer_amplitude

        if len(recordings) < 3:
            raise ConfigError("need recordings at three intensities or more", field="device")
        levels = sorted(recordings, key=float)
        amp = [tribometer_amplitude(recordings[k], fs) for k in levels]
        return cls.fit(np.array(levels, dtype=float), np.array(amp), source=source)

    @classmethod
    def kim2017(cls) -> "DeviceCurve":
        """The quadratic through the three points Kim et al. quote for EDGE-SOFT (Sec. 3.1.2,
        Fig. 2c): 0.075 N at intensity 0.1 (the lowest measured), 0.16 N at 0.7, 0.25 N at 1.0."""
        return cls(input="intensity", coefficients=(0.07314815, 0.00092593, 0.17592593),
                   source="Kim et al. 2017 Sec. 3.1.2 / Fig. 2c (EDGE-SOFT): 0.075 N @ 0.1, 0.16 N @ 0.7, 0.25 N @ 1.0")

    @classmethod
    def square_law(cls, max_force: float, input: str = "intensity", input_max: float | None = None) -> "DeviceCurve":
        """``F = max_force (u / u_max)^2``: drive proportional to the voltage, force to its square."""
        if not (np.isfinite(max_force) and max_force > 0):
            raise ConfigError("must be > 0 N", field="max_force")
        top = 1.0 if input_max is None else float(input_max)
        return cls(input=input, coefficients=(0.0, 0.0, float(max_force) / top ** 2), input_max=input_max,
                   source=f"square law, {max_force:.4g} N at {input} {top:g}")

    def summary(self) -> dict:
        return jsonable({**self.model_dump(), "max_force": self.max_force})

    def to_dict(self) -> dict:
        """The fields (what the display file holds; ``DeviceCurve(**d)`` rebuilds it)."""
        return self.model_dump(mode="json")

    def plot(self, ax=None):
        """Force over the drive."""
        from surfhap.report.shape_figures import plot_device_curve

        return plot_device_curve(self, ax)
