"""Display parameters from the user: a display JSON file or ``k=...,mu_panel=...,area=...``.

``load_display(text)`` accepts either a path to a ``surfhap-display`` file
(:mod:`surfhap.models.display`) or inline ``key=value`` pairs (keys ``k`` in N/V^2,
``mu_panel``, ``area`` in m^2, ``leakage`` in s) and returns a
:class:`~surfhap.models.panel.DisplayModel`. Missing values keep the documented assumptions.
``k`` overrides the one computed from the stack; ``area`` alone rescales the stack's contact
area (k of eq. 1 is proportional to it). Any problem raises
:class:`~surfhap.errors.ConfigError` naming the file (or option) and the field.
"""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import AliasChoices, BaseModel, ConfigDict, Field

from surfhap.errors import ConfigError
from surfhap.exchange.files import parse_pairs, read_model, validated, write_text
from surfhap.models.device_curve import DeviceCurve
from surfhap.models.display import DisplayFile
from surfhap.models.panel import DisplayModel

__all__ = ["DisplayValues", "read_display_json", "write_display_json", "load_display", "display_from_values"]


class DisplayValues(BaseModel):
    """Display values given by hand (``--display k=...`` or a config's ``[display]`` section):
    ``k`` N/V^2, ``mu_panel``, ``area`` m^2, ``leakage`` (or ``leakage_time_constant``) s; each a
    finite number > 0, unknown keys refused."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    k: float | None = Field(None, gt=0)
    mu_panel: float | None = Field(None, gt=0)
    area: float | None = Field(None, gt=0)
    leakage: float | None = Field(None, gt=0, validation_alias=AliasChoices("leakage", "leakage_time_constant"))


def display_from_values(k: float | None = None, mu_panel: float | None = None, area: float | None = None,
                        leakage: float | None = None, device_curve: DeviceCurve | None = None,
                        source: str = "command line", base: DisplayModel | None = None) -> DisplayModel:
    """A DisplayModel from the given values over ``base`` (default: the documented assumptions)."""
    base = base or DisplayModel()
    stack = base.stack if area is None else base.stack.model_validate({**base.stack.model_dump(), "contact_area": area})
    return DisplayModel(mu_panel=base.mu_panel if mu_panel is None else float(mu_panel), stack=stack,
                        leakage_time_constant=base.leakage_time_constant if leakage is None else float(leakage),
                        k_measured=base.k_measured if k is None else float(k),
                        device_curve=device_curve if device_curve is not None else base.device_curve, source=source)


def write_display_json(doc: dict, path: str | Path) -> Path:
    """Write a display file (``doc`` as :meth:`surfhap.lab.calibration.Calibration.to_display_json`
    makes it) after validating it as the reader will: a file the renderers refuse is never written."""
    validated(DisplayFile, doc, str(path), ConfigError)
    return write_text(path, json.dumps(doc, indent=2) + "\n")


def read_display_json(path: str | Path) -> DisplayModel:
    """Read and validate a display file; raises ConfigError(source=file, field=...) on any problem."""
    spec = read_model(path, DisplayFile, ConfigError)
    source = f"{Path(path).name} ({spec.provenance.source})"
    if spec.k is None:
        source += "; k not measured: the assumed stack value"
    return display_from_values(spec.k, spec.mu_panel, spec.area, spec.leakage_time_constant, spec.device_curve,
                               source=source)


def load_display(text: str | Path | None, option: str = "--display") -> DisplayModel:
    """None -> the documented assumptions; a path ending in .json (or an existing file without
    "=") -> the file; else the pairs ``k=5e-6,mu_panel=0.4,area=1e-4[,leakage=0.05]``."""
    if text is None:
        return DisplayModel()
    if str(text).lower().endswith(".json") or ("=" not in str(text) and Path(text).exists()):
        return read_display_json(text)
    values = parse_pairs(str(text), option, DisplayValues.model_fields, ConfigError, what="key=value or a display JSON file",
                         numbers=True)
    if not values:
        raise ConfigError("give k=..., mu_panel=..., area=... or a display JSON file", source=option)
    spec = validated(DisplayValues, values, option, ConfigError)
    return display_from_values(**spec.model_dump(exclude_none=True), source=f"{option} {text}")
