"""The display file schema (``"format": "surfhap-display"``, version 1): a user's measured panel.

A display file carries what the drive laws and the simulated display need to know about a
real electrostatic panel. Calibration tools write it; :mod:`surfhap.exchange.display_file`
reads it into a :class:`surfhap.models.panel.DisplayModel`::

    {"format": "surfhap-display", "version": 1,
     "k": 5.3e-6,                      # N/V^2, f_e = k V^2 (Zhao et al. eq. 1)
     "mu_panel": 0.5,                  # panel friction coefficient (Otake et al. 2022 eq. 5)
     "leakage_time_constant": 0.05,    # s, optional
     "area": 1e-4,                     # m^2, optional contact area
     "device_curve": {"input": "voltage", "coefficients": [c0, c1, c2], "input_max": 240},  # optional
     "provenance": {"source": "...", "command": "..."},
     "calibration": {...}}             # optional: what `surfhap calibrate tribometer` measured

``k`` may be null when the calibration did not measure it (a device curve over intensity):
the renderers then use the assumed stack value and say so in the display's source.

``device_curve`` is the measured lateral force ``F = c0 + c1 u + c2 u^2`` (N, ascending
coefficients) over the drive ``u`` ("intensity" or "voltage") up to ``input_max`` (optional),
as the calibration of Kim et al. produces: a :class:`surfhap.models.device_curve.DeviceCurve`.
When present, every renderer turns its target force into the drive through the curve's inverse
(:meth:`surfhap.models.panel.DisplayModel.voltage_for_force`) instead of ``V = sqrt(F / (mu_panel k))``.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from surfhap.models.device_curve import DeviceCurve

__all__ = ["DISPLAY_FORMAT", "DISPLAY_VERSION", "DisplayProvenance", "DisplayFile"]

DISPLAY_FORMAT = "surfhap-display"
DISPLAY_VERSION = 1


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class DisplayProvenance(_Strict):
    """Where the numbers came from: ``source`` (recording, paper or 'assumed') and the ``command``."""

    source: str = Field(min_length=1)
    command: str | None = None


class DisplayFile(_Strict):
    """Schema of a display JSON file (version 1), SI units."""

    format: Literal["surfhap-display"]
    version: Literal[1]
    k: float | None = Field(default=None, gt=0, le=1e-2,
                            description="N/V^2, electrostatic constant; null when the calibration did not "
                                        "measure it (an intensity-only device curve): the assumed stack value is used")
    mu_panel: float = Field(gt=0, le=5, description="panel friction coefficient")
    leakage_time_constant: float | None = Field(default=None, gt=0, le=100, description="s")
    area: float | None = Field(default=None, gt=0, le=1e-2, description="m^2 contact area")
    device_curve: DeviceCurve | None = None
    provenance: DisplayProvenance
    calibration: dict | None = Field(default=None, description="details of the calibration that wrote the file "
                                                               "(levels, amplitudes, residuals); not read by the renderers")
