"""``surfhap calibrate tribometer``: display calibration from tribometer recordings.

::

    surfhap calibrate tribometer REC1.csv REC2.csv ... --out CAL.json [--curve static|amplitude]
                                 [--volts-per-unit G] [--guard 0.1] [--plot FIG.png] [--leakage DC.csv ...]

Writes the display file (``surfhap-display`` version 1) that ``surfhap render/serve
--display CAL.json`` reads: k, mu_panel, the device curve, and the fit details. With ``--live
--sensor netft://HOST --output OUT`` it records the steps itself (:mod:`surfhap.lab.rig_calibration`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import check_out, command_line, fail, figure_path, parse_numbers, report, save_figure, stdout
from surfhap.cli._options import JsonOption, OverwriteOption
from surfhap.cli.record import NORMAL, SHEAR, open_sensor, report_status

__all__ = ["register"]

calibrate_app = typer.Typer(no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                            help="Calibrate a display: intensity or voltage -> friction force from tribometer "
                                 "recordings (Kim et al. 2017 Sec. 2.2), written as a display file.")


def _live(sensor, output, levels, step_seconds, revolution, v_max, normal, shear, sensor_timeout):
    """Play the steps on ``output``, record ``sensor``: one tribometer recording per step (exit 3
    when the sensor falls silent or the output fails, after the drive has ramped to zero)."""
    from surfhap.cli._output import parse_output
    from surfhap.cli._signals import StopSignals
    from surfhap.lab import rig_calibration as rig
    from surfhap.live.backends.output import open_backend
    from surfhap.live.engine import LiveEngine
    from surfhap.live.netft import SensorSilent
    from surfhap.render.safety import SafetyLimits
    from surfhap.runtime.clock import now

    lv = parse_numbers(levels, "--levels", "comma-separated intensities") if levels else rig.KIM_LEVELS
    schedule = rig.StepSchedule(lv, step_seconds or rig.STEP_SECONDS, revolution or rig.REVOLUTION)
    out = parse_output(output)
    limits = SafetyLimits(**({} if v_max is None else {"v_max": v_max}), watchdog_timeout=sensor_timeout)
    engine = LiveEngine(rig.StepRenderer(schedule, out.default_drive_rate, limits, now))
    engine.warm_up()  # compiled kernels loaded before the stream starts
    dev = open_sensor(sensor, "--sensor", normal, shear, timeout=1.0, silence=sensor_timeout)  # streaming (else exit 2) before any drive
    backend, failure = open_backend(out), None
    with StopSignals() as guard:
        try:
            backend.start(engine)
            stdout().print(f"playing {schedule.levels.size} intensities x {schedule.step_seconds:g} s on {output}, "
                           f"recording {dev.name}")
            t, fn, fs, level = rig.record_steps(dev, engine, schedule, keep_running=lambda: not guard.stopped)
        except SensorSilent as exc:  # the watchdog has begun the ramp to zero; the stop ramp ends it
            failure = str(exc)
        finally:
            dev.close()
            backend.stop()
    guard.finish("the drive ramped to zero; nothing written")
    if failure or engine.failure:
        fail(f"{failure or engine.failure}; the drive ramped to zero", 3)
    report_status(dev)
    stdout().print(f"recorded {t.size} samples, {dev.gaps} gaps ({dev.lost} records lost)")
    return rig.step_recordings(t, fn, fs, level, schedule, dev.rate, limits.v_max, dev.name)


@calibrate_app.command("tribometer")
def tribometer(
    recordings: Optional[list[Path]] = typer.Argument(None, help="Tribometer recordings (.csv/.npz, one drive level "
                                                                "each; schema in docs/lab.md). Three levels or more; "
                                                                "none with --live."),
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
    live: bool = typer.Option(False, "--live", help="Record on the rig instead: play Kim et al.'s intensity steps "
                                                    "on --output, record --sensor (docs/live.md 'Your rig')."),
    sensor: Optional[str] = typer.Option(None, "--sensor", help="--live: netft://HOST[:PORT][?http=PORT]."),
    output: str = typer.Option("sim", "--output", help="--live: where the drive goes (sim, sound[:DEVICE], ...)."),
    levels: Optional[str] = typer.Option(None, "--levels", help="--live: intensities, comma-separated (Kim et al. "
                                                                "Sec. 2.2: 0.1, 0.2, ..., 1.0)."),
    step_seconds: Optional[float] = typer.Option(None, "--step-seconds", help="--live: s per intensity (Kim: 20)."),
    revolution: Optional[float] = typer.Option(None, "--revolution", help="--live: s per on/off cycle, on for 1/8 "
                                                                          "(Kim: 2 pi 3 cm / 6.5 cm/s = 2.9)."),
    v_max: Optional[float] = typer.Option(None, "--v-max", help="--live: V at intensity 1, the safety limit (250)."),
    sensor_timeout: float = typer.Option(0.020, "--sensor-timeout", min=0.001, max=1.0,
                                         help="--live: s without a sensor record before the drive ramps to zero "
                                              "and the command ends, exit 3 (issue 19's fail-safe: 20 ms)."),
    normal: str = NORMAL,
    shear: str = SHEAR,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Fit the device curve and k, mu_panel from tribometer recordings; write CAL.json."""
    from surfhap.exchange.display_file import write_display_json
    from surfhap.exchange.tribometer import read_tribometer
    from surfhap.lab.calibration import calibrate

    plot = figure_path(plot, "--plot")
    check_out(out, "--out", overwrite)
    if live == bool(recordings) or live != bool(sensor):
        fail("give tribometer recordings, or --live with --sensor (and no recordings)")
    recs = _live(sensor, output, levels, step_seconds, revolution, v_max, normal, shear, sensor_timeout) if live else \
        [read_tribometer(p) for p in recordings]
    leaks = [read_tribometer(p) for p in (leakage or [])]
    cal = calibrate(recs, curve=curve, guard=guard, volts_per_unit=volts_per_unit, leakage_recordings=leaks)
    rig_options = dict(sensor=sensor, output=output, levels=levels, step_seconds=step_seconds, revolution=revolution,
                       v_max=v_max, sensor_timeout=sensor_timeout, normal=normal, shear=shear) if live else {}
    command = command_line("calibrate", "tribometer", *(recordings or []), out=out, curve=curve, guard=guard,
                           volts_per_unit=volts_per_unit or None, leakage=leakage, live=live, **rig_options)
    doc = cal.to_display_json(source=sensor if live else ", ".join(p.name for p in recordings), command=command)
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
        save_figure(cal.plot(), plot, dpi=120)
        lines.append(f"wrote {plot}")
    report({**cal.summary(), "out": str(out), "plot": plot and str(plot)}, [*lines, f"wrote {out}"], as_json)


def register(app: typer.Typer) -> None:
    app.add_typer(calibrate_app, name="calibrate")
