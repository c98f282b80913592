"""The options shared by the commands that render for a display (cli/_options.py): ``--display``,
``--load-range``, ``--speed-range`` and ``--config FILE.toml`` (a ``[display]`` section).

Precedence: command-line options, then the config file, then the documented assumptions.
The ``[display]`` section may hold ``file`` (a display JSON, relative to the config file),
``k`` (N/V^2), ``mu_panel``, ``area`` (m^2), ``leakage_time_constant`` (s), ``load_range``
([low, high] N) and ``speed_range`` ([low, high] m/s).
"""

from __future__ import annotations

from pathlib import Path

from surfhap.cli._common import parse_numbers
from surfhap.errors import ConfigError

__all__ = ["resolve_display_and_range", "resolve_display"]


def _read_config(path: Path):
    """The ``[display]`` section of a config file, validated (unknown keys refused)."""
    import tomllib

    from pydantic import Field

    from surfhap.exchange.display_file import DisplayValues
    from surfhap.exchange.files import validated

    class DisplaySection(DisplayValues):
        file: str | None = None
        load_range: list[float] | None = Field(None, min_length=2, max_length=2)  # [low, high] N
        speed_range: list[float] | None = Field(None, min_length=2, max_length=2)  # [low, high] m/s

    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(f"cannot read file ({exc.strerror})", source=str(path)) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"malformed TOML ({exc})", source=str(path)) from None
    return validated(DisplaySection, raw.get("display", {}), str(path), ConfigError, prefix="display.")


def resolve_display_and_range(display: str | None, load_range: str | None, speed_range: str | None,
                              config: Path | None):
    """Returns (DisplayModel, OperatingRange) from the options; ConfigError names the culprit."""
    from surfhap.exchange.display_file import DisplayValues, display_from_values, load_display
    from surfhap.render.gain_plan import OperatingRange

    sec = _read_config(Path(config)) if config is not None else None
    src = str(config) if config is not None else ""
    if display is not None or sec is None:
        model = load_display(display)
    else:
        base = load_display(str(Path(config).parent / sec.file)) if sec.file else None
        vals = sec.model_dump(include=set(DisplayValues.model_fields), exclude_none=True)
        model = display_from_values(**vals, source=f"{src} [display]", base=base) if (vals or base is None) else base
    default = OperatingRange()
    loads = parse_numbers(load_range, "--load-range", "LOW,HIGH (two numbers)", 2) if load_range is not None else tuple((sec and sec.load_range) or default.loads)
    speeds = (parse_numbers(speed_range, "--speed-range", "LOW,HIGH (two numbers)", 2) if speed_range is not None
              else tuple((sec and sec.speed_range) or default.speeds))
    try:
        rng = OperatingRange(loads=loads, speeds=speeds)
    except ConfigError as exc:
        opt = "--load-range" if (exc.field or "").startswith("loads") else "--speed-range"
        raise ConfigError(exc.message, source=opt if (load_range or speed_range) else (src or opt)) from None
    return model, rng


def resolve_display(display: str | None, config: Path | None = None):
    """The DisplayModel of ``--display`` / ``--config`` (the documented assumptions without either)."""
    return resolve_display_and_range(display, None, None, config)[0]
