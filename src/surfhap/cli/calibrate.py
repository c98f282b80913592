"""``surfhap calibrate tribometer``: display calibration from tribometer recordings.

::

    surfhap calibrate tribometer REC1.csv REC2.csv ... --out CAL.json [--curve static|amplitude]
                                 [--volts-per-unit G] [--guard 0.1] [--plot FIG.png] [--leakage DC.csv ...]

Writes the display file (``surfhap-display`` version 1) that ``surfhap render/serve
--display CAL.json`` reads: k, mu_panel, the device curve, and the fit details.
"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import check_out, figure_path, report
from surfhap.cli._options import JsonOption, OverwriteOption

__all__ = ["register"]

calibrate_app = typer.Typer(no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                            help="Calibrate a display: intensity or voltage -> friction force from tribometer "
                                 "recordings (Kim et al. 2017 Sec. 2.2), written as a display file.")


@calibrate_app.command("tribometer")
def tribometer(
    recordings: list[Path] = typer.Argument(..., help="Tribometer recordings (.csv/.npz, one drive level each; "
                                                      "schema in docs/lab.md). Three levels or more."),
    out: Path = typer.Option(..., "--out", help="Display file to write (JSON)."),
    curve: str = typer.Option("static", "--curve", help="Device curve quantity: 'static' (static friction "
                                                        "increase, what the drive laws plan) or 'amplitude' "
                                                        "(peak-to-peak vibration, Kim et al. Fig. 2c)."),
    volts_per_unit: Optional[float] = typer.Option(None, "--volts-per-unit",
                                                   help="Intensity input only: amplifier gain (V per unit "
                                                        "intensity), to derive k."),
    guard: float = typer.Option(0.1, "--guard", help="Seconds ignored after each on/off switch."),
    leakage: Optional[list[Path]] = typer.Option(None, "--leakage", help="Recordings with a DC drive (no polarity "
                                                                         "carrier, voltage input) to measure the "
                                                                         "charge-leakage time constant; repeatable."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Also save a figure of the fits (PNG/PDF/SVG)."),
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Fit the device curve and k, mu_panel from tribometer recordings; write CAL.json."""
    from surfhap.exchange.display_file import write_display_json
    from surfhap.exchange.tribometer import read_tribometer
    from surfhap.lab.calibration import calibrate

    plot = figure_path(plot, "--plot")
    check_out(out, "--out", overwrite)
    recs = [read_tribometer(p) for p in recordings]
    leaks = [read_tribometer(p) for p in (leakage or [])]
    cal = calibrate(recs, curve=curve, guard=guard, volts_per_unit=volts_per_unit, leakage_recordings=leaks)
    opts = f" --curve {curve} --guard {guard:g}" + (f" --volts-per-unit {volts_per_unit:g}" if volts_per_unit else "")
    opts += "".join(f" --leakage {shlex.quote(str(p))}" for p in (leakage or []))
    command = ("surfhap calibrate tribometer " + " ".join(shlex.quote(str(p)) for p in recordings)
               + f" --out {shlex.quote(str(out))}" + opts)
    doc = cal.to_display_json(source=", ".join(p.name for p in recordings), command=command)
    write_display_json(doc, out)
    c0, c1, c2 = cal.device_fit.coefficients
    lines = [f"{len(recs)} recordings, {cal.input} levels {cal.levels.min():g}..{cal.levels.max():g}",
             f"device curve ({cal.curve}): F = {c0:.4g} + {c1:.4g} L + {c2:.4g} L^2  "
             f"(rmse {cal.device_fit.rmse * 1e3:.3g} mN)",
             f"mu_panel = {cal.mu_panel:.4g}" + (f", k = {cal.k:.4g} N/V^2" if cal.k is not None else
                                                ", k unknown (intensity input, no --volts-per-unit)")]
    if cal.leakage is not None:
        lines.append(f"leakage time constant {cal.leakage.time_constant * 1e3:.1f} ms "
                     f"({len(cal.leakage.per_recording)} DC recordings)")
    if plot is not None:
        plot.parent.mkdir(parents=True, exist_ok=True)
        cal.plot().savefig(plot, dpi=120)
        lines.append(f"wrote {plot}")
    report({**cal.summary(), "out": str(out), "plot": plot and str(plot)}, [*lines, f"wrote {out}"], as_json)


def register(app: typer.Typer) -> None:
    app.add_typer(calibrate_app, name="calibrate")
