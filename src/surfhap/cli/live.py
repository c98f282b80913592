"""``surfhap serve`` / ``devices`` / ``play``: live rendering to a sound card, OSC, a file or
the simulated display, with a touch page in the browser.

Ctrl-C and SIGTERM stop the same way (:class:`~surfhap.cli._signals.StopSignals`): the
output ramps to zero (``stop_ramp``, 10 ms), the recording is flushed, the status is printed
(a summary; one JSON line with ``--json``), one ``interrupted`` line, exit code 130 (0 when ``play`` or ``serve --duration``
ended by itself). Exit code 3: the output backend failed (raised or stalled); the engine
drove 0 V from then on and the status's ``failure`` says why.
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Annotated, List, Optional

import typer

from surfhap.cli._output import parse_output
from surfhap.cli._common import fail, parse_numbers, report, require_modules, stdout, warning_line
from surfhap.cli._display_options import resolve_display
from surfhap.cli._options import (ConfigOption, DisplayOption, JsonOption, LiveAmpGainOption, SeedOption,
                                  TrajectoryOption)
from surfhap.cli._signals import StopSignals
from surfhap.errors import ConfigError

__all__ = ["register"]

LOOPBACK = ("127.0.0.1", "localhost", "::1")
DEFAULT_SCAN = "speed=0.1,load=0.5,duration=3,length=0.08"
ClockOption = typer.Option("wall", "--clock", help="wall: real time | sim: as fast as possible, the --trajectory's "
                           "samples arriving at their stamps (the drive equals `surfhap render` on it; no page).")
DriveRateOption = Annotated[Optional[int], typer.Option("--drive-rate", help="DAC rate, Hz (default 48000 for sound, else 20000).")]
ChannelsOption = Annotated[Optional[str], typer.Option("--channels", help="Sound output: 0-based channels that carry the drive, any of the card's, e.g. '0' or '1,3,5'; the others stay silent (default: all).")]
BlockMsOption = Annotated[float, typer.Option("--block-ms", help="Block period, ms.")]


def _clock(name: str):
    from surfhap.runtime.clock import SimClock, WallClock

    if name not in ("sim", "wall"):
        raise ConfigError(f"must be sim or wall, got {name!r}", source="--clock")
    return SimClock() if name == "sim" else WallClock()


def _status_lines(title: str, output: str, st: dict) -> list[str]:
    """The human summary of an engine status (``play``, ``serve``)."""
    c, sf = st["counters"], st["safety"]
    return [f"{title} -> {output}: {c['frames']} samples in {c['blocks']} blocks from {c['touches']} touches; "
            f"{c['underruns']} underruns, {c['overruns']} overruns, {c['errors']} errors",
            f"safety: {sf['clamped']} samples clamped, {sf['rise_limited']} rise-limited, {sf['faults']} faults, "
            f"{sf['watchdog']} watchdog stops; output {'stopped (0 V)' if st['stopped'] else 'running'}"
            + (f"; failed: {st['failure']}" if st["failure"] else "")]


def _print_status(session, output: str, touches: int, as_json: bool, **extra) -> None:
    """The status of a ``play`` or a simulated run: a summary, or one JSON line (``--json``)."""
    st = session.engine.status()
    report({"material": session.title, "output": output, **extra, "touches": touches,
            **{k: st[k] for k in ("counters", "safety", "output_safety", "stopped", "failure")}},
           _status_lines(session.title, output, st), as_json)


def _run_simulated(session, traj, output: str, clock, as_json: bool) -> None:
    """``--clock sim``: the trajectory through the engine into the output, as fast as possible;
    prints the status (exit 3 when the output failed)."""
    n = session.run_simulated(traj, clock)
    _print_status(session, output, session.replay_sent, as_json, clock="sim", frames=n)
    _finish(session.engine, None)


def _finish(engine, guard: StopSignals | None) -> None:
    """Exit 3 (after the status was printed) when the output backend failed, else 130 when a
    signal stopped the command (``guard``; None for a simulated run)."""
    if engine.failure is not None:
        fail(f"{engine.failure}; the output was halted at 0 V", 3)
    if guard is not None:
        guard.finish("the output ramped to 0 V, status above")


def _engine_config(block_ms: float, touch_latency_ms: float, smoothing: float):
    from surfhap.live.engine_config import EngineConfig

    return EngineConfig(block_seconds=block_ms * 1e-3, touch_latency=touch_latency_ms * 1e-3, smoothing=smoothing)


def _channels(text: str | None) -> tuple[int, ...] | None:
    """``--channels`` '0,2' -> (0, 2)."""
    if text is None:
        return None
    chans = parse_numbers(text, "--channels", "0-based channel numbers like 0,2", kind=int)
    if any(c < 0 or c > 255 for c in chans):
        raise ConfigError("channels must be within 0-255", source="--channels")
    return chans


def _allowed_hosts(host: str, values: list[str]) -> tuple[str, ...]:
    """The ``--allow-host`` names (repeatable, comma-separated), checked. A bind other
    than loopback needs at least one: otherwise a page on any web site could reach the
    server through a DNS name it controls (DNS rebinding)."""
    names = []
    for v in values:
        for n in v.split(","):
            n = n.strip().lower()
            if not n:
                continue
            if n == "*" or "/" in n or " " in n or (n.count("*") and not (n.startswith("*.") and n.count("*") == 1)):
                raise ConfigError(f"{n!r} is not a host name (give names like lab-pc.local or *.lab.example)",
                                  source="--allow-host")
            names.append(n)
    if host not in LOOPBACK and not names:
        raise ConfigError(f"binding {host} needs --allow-host NAME: the host names the page is opened by "
                          "(e.g. --allow-host lab-pc.local,192.168.1.20); other Host headers are refused",
                          source="--host")
    return tuple(names)


SENSOR = typer.Option(None, "--sensor", help="Close the friction loop over a force sensor: netft://HOST[:PORT] (an ATI Net F/T under the panel, +Fz normal, +Fx shear, as 'record force') or 'sim' (a simulated sensor on the simulated display, whose k drifts); see docs/live.md.")


def _sensor(text: str | None):
    """The --sensor option: None, "sim", or a started Net F/T sensor (a box silent at the start:
    exit 2). Silence later is the loop's to handle: it falls back to open loop
    (runtime/closed_loop.py) and closes again when records return; it does not end the session."""
    if text is None or not text.startswith("netft://"):
        return text
    from surfhap.cli.record import open_sensor

    return open_sensor(text, "--sensor", "z", "x", 1.0, silence=math.inf)


def serve_cmd(
    material: Optional[str] = typer.Option(None, "--material", help="Built-in material name or material file (default: cork)."),
    mesh: Optional[str] = typer.Option(None, "--mesh", help="Render a 3-D mesh instead of a material: a mesh file (OBJ, STL, PLY, ...) or a built-in shape name as 'surfhap shape' takes (suzanne, gaussian-bump, ...); it is scaled to fit the touch surface."),
    output: str = typer.Option("sim", "--output", help="sim | sound[:DEVICE] | file:PATH.wav|.npz | osc://HOST:PORT\\[/intensity|/drive] | daq:DEV/aoN."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to bind. Anything but loopback exposes the page to your network."),
    port: int = typer.Option(8765, "--port", help="TCP port of the page."),
    allow_origin: List[str] = typer.Option([], "--allow-origin", help="Extra WebSocket origin to accept (repeatable), e.g. https://lab.example:8443."),
    allow_host: List[str] = typer.Option([], "--allow-host", help="Host name the page may be opened by (repeatable or comma-separated, *.domain allowed). Required when --host is not loopback; other Host headers are refused (DNS rebinding)."),
    osc_in: Optional[str] = typer.Option(None, "--osc-in", help="Also accept OSC touch messages on HOST:PORT (UDP), e.g. 127.0.0.1:9000."),
    replay: Optional[Path] = typer.Option(None, "--replay", help="Also replay a trajectory CSV (time, x, y, load) as a touch source."),
    trajectory: TrajectoryOption = None,
    clock: str = ClockOption,
    drive_rate: DriveRateOption = None,
    amp_gain: LiveAmpGainOption = 250.0,
    channels: ChannelsOption = None,
    block_ms: BlockMsOption = 1.0,
    touch_latency_ms: float = typer.Option(0.0, "--touch-latency-ms", help="Touch latency to compensate by prediction, ms (0 = off)."),
    smoothing: float = typer.Option(1.0, "--smoothing", help="Exponential smoothing of predicted positions, (0, 1] (1 = off; KinesTouch: 0.15)."),
    seed: SeedOption = 0,
    duration: float = typer.Option(0.0, "--duration", help="Stop after this many seconds (0 = until Ctrl-C)."),
    max_seconds: Optional[float] = typer.Option(None, "--max-seconds", help="File output: end the recording with the stop ramp after this many seconds, warn and stop (default: no limit)."),
    web_process: bool = typer.Option(True, "--web-process/--no-web-process",
                                     help="Run the page server in its own process, so web traffic cannot delay the engine."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log connections and rejected messages at INFO."),
    sensor: Optional[str] = SENSOR,
    display: DisplayOption = None,
    config: ConfigOption = None,
    as_json: JsonOption = False,
) -> None:
    """Serve the touch page: drag on it and the drive is rendered live to the chosen output.

    Ctrl-C or SIGTERM ramps the output to zero, writes the recording and prints the status
    (exit 130); exit 3 when the output backend failed."""
    require_modules("fastapi", "starlette", "uvicorn")  # the page; else: install surfhap[live]
    from surfhap.exchange.trajectory_csv import read_trajectory_csv
    from surfhap.live.config import ServerConfig
    from surfhap.live.logfilter import configure_logging
    from surfhap.live.netaddr import parse_host_port
    from surfhap.live.session import backend_info, build_session
    from surfhap.web import create_app
    from surfhap.web.process import WebProcess
    from surfhap.web.server import ServerThread

    configure_logging(verbose)  # rate-limited: one line per kind per second, whatever a client provokes
    logging.getLogger("surfhap").setLevel(logging.INFO)
    disp = resolve_display(display, config)
    if mesh is not None and material is not None:
        raise ConfigError("give --material or --mesh, not both", source="--mesh")
    if not 1 <= port <= 65535:
        raise ConfigError("must be within 1-65535", source="--port")
    allowed_hosts = _allowed_hosts(host, allow_host)
    osc = parse_host_port(osc_in, "--osc-in", listen=True) if osc_in else None
    if host not in LOOPBACK:
        warning_line(f"binding {host}: the page is reachable from your network; anyone who can reach it can drive "
                     "the display")
    if osc is not None and osc[0] not in LOOPBACK:
        warning_line(f"--osc-in binds {osc[0]}: OSC touch input is reachable from your network; anyone who can send "
                     "it a datagram can drive the display")
    clk = _clock(clock)
    if clk.simulated and trajectory is None:
        raise ConfigError("a simulated clock needs --trajectory FILE (there is no page to touch)", source="--clock")
    if trajectory is not None and replay is not None:
        raise ConfigError("give --trajectory or --replay, not both", source="--trajectory")
    traj = read_trajectory_csv(trajectory or replay) if (trajectory or replay) is not None else None
    session = build_session(material or "cork", parse_output(output), drive_rate=drive_rate, amp_gain=amp_gain,
                            engine_config=_engine_config(block_ms, touch_latency_ms, smoothing),
                            osc_in=osc, replay=None if clk.simulated else traj, replay_loop=replay is not None,
                            seed=seed, mesh=mesh, channels=_channels(channels), max_seconds=max_seconds,
                            display=disp, clock=clk, sensor=_sensor(sensor))
    if clk.simulated:
        return _run_simulated(session, traj, output, clk, as_json)
    cfg = ServerConfig(host=host, port=port, allowed_origins=tuple(allow_origin), allowed_hosts=allowed_hosts)
    server = None
    with StopSignals() as guard:
        try:
            session.start()
            if web_process:
                server = WebProcess(session, cfg).start()
            else:
                server = ServerThread(create_app(cfg, touch=session), host=host, port=port, config=cfg).start()
            shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
            shown = f"[{shown}]" if ":" in shown else shown
            stdout().print(f"surfhap live: {session.title} -> {output}; open http://{shown}:{port}/ (Ctrl-C stops)")
            end = time.monotonic() + duration if duration > 0 else None
            while ((end is None or time.monotonic() < end) and session.engine.failure is None
                   and not session.engine.stopped and not guard.wait(0.05)):
                pass
        except OSError as exc:
            raise ConfigError(f"cannot listen on {host}:{port} ({exc.strerror or exc})", source="--port") from None
        finally:  # the output first: its stop ramp runs while the page still delivers touches
            session.stop()
            if server is not None:
                server.stop()
    st = session.engine.status()
    report(dict(st, output=backend_info(session.backend)), _status_lines(session.title, output, st), as_json)
    _finish(session.engine, guard)


def devices_cmd() -> None:
    """List the sound devices PortAudio can output to (use the index with --output sound:N)."""
    from surfhap.live.backends.sound import list_devices

    devs = list_devices()
    if not devs:
        stdout().print("no output devices found")
        return
    for d in devs:
        stdout().print(f"{d['index']:>3}  {d['name']}  [{d['hostapi']}]  {d['channels']} ch  {d['default_rate']:.0f} Hz")


def play_cmd(
    material: str = typer.Argument(..., help="Built-in material name or material file."),
    output: str = typer.Option("sim", "--output", help="sound[:DEVICE] | sim | file:PATH.wav|.npz | osc://HOST:PORT | daq:DEV/aoN."),
    scan: Optional[str] = typer.Option(None, "--scan", help="Scripted strokes: 'speed=M/S,load=N,duration=S[,length=M][,rate=HZ]' "
                                       f"(default {DEFAULT_SCAN})."),
    trajectory: TrajectoryOption = None,
    clock: str = ClockOption,
    drive_rate: DriveRateOption = None,
    amp_gain: LiveAmpGainOption = 250.0,
    channels: ChannelsOption = None,
    block_ms: BlockMsOption = 1.0,
    seed: SeedOption = 0,
    sensor: Optional[str] = SENSOR,
    display: DisplayOption = None,
    config: ConfigOption = None,
    as_json: JsonOption = False,
) -> None:
    """Play a scripted scan of MATERIAL live, to check the sound card and amplifier chain.

    Ctrl-C or SIGTERM ramps the output to zero, writes the recording and prints the status
    (exit 130); exit 3 when the output backend failed."""
    from surfhap.cli._scan import trajectory_from_options
    from surfhap.live.session import build_session

    disp = resolve_display(display, config)
    clk = _clock(clock)
    traj = trajectory_from_options(scan if scan is not None or trajectory is not None else DEFAULT_SCAN, trajectory)
    if not clk.simulated and not traj.duration <= 600:
        raise ConfigError("must be within (0, 600] s on a wall clock", source="--scan/--trajectory", field="duration")
    session = build_session(material, parse_output(output), drive_rate=drive_rate, amp_gain=amp_gain,
                            engine_config=_engine_config(block_ms, 0.0, 1.0), replay=None if clk.simulated else traj,
                            seed=seed, channels=_channels(channels), display=disp, clock=clk, sensor=_sensor(sensor))
    if clk.simulated:
        return _run_simulated(session, traj, output, clk, as_json)
    replay = session.sources[0]
    with StopSignals() as guard:
        try:
            session.start()
            end = time.monotonic() + traj.duration + 5.0
            while (not replay.done.is_set() and time.monotonic() < end and session.engine.failure is None
                   and not guard.wait(0.05)):
                pass
            guard.wait(0.05)
        finally:
            session.stop()
    _print_status(session, output, replay.sent, as_json, latency=session.engine.status()["latency"])
    _finish(session.engine, guard)


def register(app: typer.Typer) -> None:
    app.command("serve")(serve_cmd)
    app.command("devices")(devices_cmd)
    app.command("play")(play_cmd)
