"""``surfhap record force``: record a rig's force sensor into the recording CSV that ``fit friction`` reads.

::

    surfhap record force netft://HOST[:PORT][?http=PORT] --duration S --out FILE.csv [--normal z] [--shear x]

Columns ``time,normal_force,shear_force`` (s, N, N; time on the box's clock) with metadata
lines ``# sensor``, ``# gaps``, ``# lost_records``, ``# status_errors``. A silent box is one
line naming its address, exit 2.
"""

from __future__ import annotations

from pathlib import Path

import typer

from surfhap.cli._common import check_out, stdout, warning_line
from surfhap.cli._options import OverwriteOption

__all__ = ["register", "open_sensor", "report_status", "NORMAL", "SHEAR"]

record_app = typer.Typer(no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                         help="Record a rig's sensors (ATI Net F/T over RDT).")


# the axis options of every command that opens a force sensor
NORMAL = typer.Option("z", "--normal", help="Sensor axis of the normal force, optionally signed (z, -z, x, ...): "
                                            "pressing on the panel must read positive.")
SHEAR = typer.Option("x", "--shear", help="Sensor axis of the shear (friction) force, optionally signed.")


def open_sensor(text: str, option: str, normal: str, shear: str, timeout: float, silence: float | None = None):
    """The ForceSensor of ``netft://HOST[:PORT][?http=PORT]`` (stream started; ``timeout``,
    ``silence``: :class:`~surfhap.live.netft.NetFT`'s)."""
    from surfhap.live.netaddr import parse_netft_address
    from surfhap.live.netft import NetFT

    host, port, http = parse_netft_address(text, option)
    return NetFT(host, port, http_port=http, normal=normal, shear=shear, timeout=timeout, silence=silence)


def report_status(sensor) -> None:
    """One warning line when the box flagged records with a non-zero status word."""
    if sensor.status_count:
        warning_line(f"{sensor.name}: status 0x{sensor.first_status:08x} in {sensor.status_count} records "
                     "(the box flags an error: see its web page)")


@record_app.command("force")
def force(
    sensor: str = typer.Argument(..., help="netft://HOST[:PORT][?http=PORT]: an ATI Net F/T box (RDT port 49152, "
                                           "configuration page on HTTP port 80 by default)."),
    duration: float = typer.Option(..., "--duration", min=0.001, help="Seconds to record (on the box's clock)."),
    out: Path = typer.Option(..., "--out", help="Recording CSV to write (time, normal_force, shear_force)."),
    normal: str = NORMAL,
    shear: str = SHEAR,
    timeout: float = typer.Option(1.0, "--timeout", min=0.001, max=60.0,
                                  help="Seconds without a record before the box counts as silent (exit 2): the box "
                                       "answers within one RDT period; 1 s also covers address resolution."),
    overwrite: OverwriteOption = False,
) -> None:
    """Record normal and shear force from a Net F/T box for --duration seconds."""
    import numpy as np

    from surfhap.cli._signals import StopSignals
    from surfhap.exchange.recordings import Recording, write_recording_csv

    check_out(out, "--out", overwrite)
    dev = open_sensor(sensor, "SENSOR", normal, shear, timeout)
    parts: list[tuple] = []
    with StopSignals() as guard:
        try:
            last = -1.0
            while last < duration - 0.5 / dev.rate and not guard.stopped:
                t, fn, fs = dev.read()
                if t.size:
                    parts.append((t, fn, fs))
                    last = float(t[-1])
                guard.wait(0.001)
        finally:
            dev.close()
    guard.finish(f"{out} not written")
    t, fn, fs = (np.concatenate(c) for c in zip(*parts))
    keep = t < duration
    meta = {"sensor": dev.name, "sample_rate_hz": f"{dev.rate:g}", "gaps": dev.gaps, "lost_records": dev.lost,
            "status_errors": dev.status_count}
    rec = Recording(str(out), t[keep], {"normal_force": fn[keep], "shear_force": fs[keep]}, participant=out.stem,
                    meta=meta)
    write_recording_csv(rec, out)
    report_status(dev)
    stdout().print(f"wrote {out}: {int(keep.sum())} samples at {dev.rate:g} Hz, {dev.gaps} gaps "
                   f"({dev.lost} records lost), from {dev.name}")


def register(app: typer.Typer) -> None:
    app.add_typer(record_app, name="record")
