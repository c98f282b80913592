"""``surfhap ff bridge-check osc://HOST:PORT``: test a running force-feedback bridge against the
OSC bridge contract (docs/forcefeedback.md); a pass/fail table, exit 0 all pass, 1 any fails."""

from __future__ import annotations

import socket
from typing import Optional

import typer

from surfhap.cli._common import print_table, stdout
from surfhap.errors import ConfigError

__all__ = ["bridge_check_cmd"]


def bridge_check_cmd(
    url: str = typer.Argument(..., help="osc://HOST:PORT where the bridge receives /surfhap/ff/force."),
    listen: str = typer.Option("127.0.0.1:9101", "--listen", help="HOST:PORT the bridge sends /surfhap/ff/position to (as ff run --device-listen)."),
    gain: float = typer.Option(4.5, "--gain", help="Device units per newton (4.5: a Falcon through CHAI3D)."),
    limit: Optional[float] = typer.Option(None, "--limit", help="Largest applied force per axis the bridge may report, device units (default: gain x 8 N)."),
    force: float = typer.Option(1.0, "--force", help="Force of the axes and watchdog rows, N (0.1-4)."),
    tolerance_ms: float = typer.Option(5.0, "--tolerance-ms", help="Added to the 20 ms watchdog for delivery delays on a busy host, ms (0-1000)."),
    trials: int = typer.Option(3, "--trials", help="Watchdog trials; the worst counts (1-20)."),
    clamp: bool = typer.Option(False, "--clamp", help="Also check the clamp: drives the device at the bridge's full limit for 30 ms (the device free, nothing held on it)."),
) -> None:
    """Test a running bridge: reply, rate, sequence numbers, units, axes, non-finite forces and
    the 20 ms watchdog, with small forces; --clamp adds the full-scale clamp row."""
    from surfhap.live.ff_bridge_check import BridgeCheck, BridgeSettings
    from surfhap.live.netaddr import parse_host_port, parse_url

    host, port = parse_url(url, "URL")
    if port == 0:
        raise ConfigError("the bridge's port must be within 1-65535", source="URL")
    lh, lp = parse_host_port(listen, "--listen", listen=True)
    try:
        settings = BridgeSettings(gain=gain, limit=gain * 8.0 if limit is None else limit, force=force,
                                  tolerance_ms=tolerance_ms, trials=trials, full_scale=clamp)
    except ConfigError as exc:
        raise ConfigError(exc.message, source="--" + (exc.field or "").replace("_", "-")) from None
    try:
        rows = BridgeCheck(host, port, settings, listen=(lh, lp)).run()
    except socket.gaierror as exc:
        raise ConfigError(f"cannot resolve {host!r} ({exc.strerror or exc})", source="URL") from None
    except OSError as exc:
        raise ConfigError(f"cannot listen ({exc.strerror or exc})", source="--listen") from None
    if stdout().is_terminal:
        from rich.text import Text

        print_table(("check", "result", "detail"), [(r.name, Text("PASS", "green") if r.passed else Text("FAIL", "red"),
                                                      r.detail) for r in rows], title=f"bridge {host}:{port}")
    else:
        for r in rows:
            typer.echo(f"{'PASS' if r.passed else 'FAIL'} {r.name:<9} {r.detail}")
    if not all(r.passed for r in rows):
        raise typer.Exit(1)
