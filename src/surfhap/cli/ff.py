"""``surfhap ff``: force-feedback touchscreen (KinesTouch): list scenes, simulate, run live."""

from __future__ import annotations

import json
import time
from dataclasses import fields
from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import check_out, fail, report, require_modules, stderr, stdout
from surfhap.cli._options import JsonOption, OverwriteOption
from surfhap.cli._signals import StopSignals
from surfhap.errors import ConfigError

__all__ = ["register"]

ff_app = typer.Typer(name="ff", no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                     help="Force-feedback touchscreen (a 3-DoF impedance device moving the tablet, KinesTouch): "
                          "stiffness, shape, roughness and sliding effects over a scene.")

PAPER_LATENCY_MS = 40.0  # "a few dozens of ms" (004 Sec. 4.2); the 40 ms
_PRED_OPTIONS = {"latency": "--touch-latency-ms", "alpha": "--smoothing", "k_pred": "--k-pred",
                 "velocity_alpha": "--velocity-alpha"}


def _device(gain: Optional[float], slew: Optional[float], f_max: Optional[float]):
    from surfhap.ff.params import DeviceParams

    triple = None if f_max is None else (f_max,) * 3
    kw = {k: v for k, v in (("gain", gain), ("slew", slew), ("f_max", triple)) if v is not None}
    try:
        return DeviceParams(**kw)
    except ConfigError as exc:
        raise ConfigError(exc.message, source=f"--{(exc.field or 'device').replace('_', '-')}") from None


def _engine(scene, dev, predict: bool, latency_ms: float, k_pred: Optional[float], smoothing: float,
            velocity_alpha: float, old_alpha: Optional[float] = None):
    """The force-feedback engine of ``scene`` on ``dev`` with the touch predictor of the options."""
    from surfhap.ff.engine import FFEngine
    from surfhap.render.kinematics import TouchPredictor

    if old_alpha is not None:
        raise ConfigError("renamed --smoothing (the position smoothing of eq. 7); --alpha is the V/sqrt(N) gain "
                          "of render and play", source="--alpha")
    try:  # the predictor's own range checks (one check), located by the option
        checked = TouchPredictor(latency=latency_ms * 1e-3, alpha=smoothing, k_pred=k_pred,
                                 velocity_alpha=velocity_alpha)
    except ConfigError as exc:
        raise ConfigError(exc.message, source=_PRED_OPTIONS.get(exc.field), field=exc.field) from None
    pred = checked if predict else TouchPredictor(velocity_alpha=velocity_alpha)
    return FFEngine(scene.effects, dev, pred, touch_latency=latency_ms * 1e-3, buttons=scene.buttons)


def _default_trajectory(scene):
    """Without --trajectory: 0.5 Hz strokes of +-3 cm through the content centre, 1 N, 6 s (the
    study's pace, 004 Sec. 5.2); on a scene with GUI buttons, one push on the centre of each
    button in turn: 0.8 s each, the load ramped 0 -> 1 N -> 0 (enough to click a button pushed
    0.8 mm at up to ~1200 N/m), then lifted."""
    import numpy as np

    from surfhap.models.trajectory import Trajectory

    buttons, (w, h) = scene.buttons, scene.size
    if not buttons:
        t = np.arange(0.0, 6.0, 1e-3)
        return Trajectory(t, w / 2 + 0.03 * np.sin(np.pi * t), np.full(t.size, h / 2), np.ones(t.size),
                          name="strokes 0.5 Hz +-3 cm, 1 N")
    t = np.arange(0.0, 0.8 * len(buttons), 1e-3)
    k = np.minimum((t // 0.8).astype(int), len(buttons) - 1)
    load = np.interp(t % 0.8, [0.0, 0.05, 0.35, 0.65, 0.7, 0.8], [0.0, 0.05, 1.0, 0.05, 0.0, 0.0])
    cx = np.array([(b.x0 + b.x1) / 2 for b in buttons])[k]
    cy = np.array([(b.y0 + b.y1) / 2 for b in buttons])[k]
    return Trajectory(t, cx, cy, load, name="one 1 N push per button")


# Options shared by simulate and run
_LAT = typer.Option(None, "--touch-latency-ms", help="Touch latency of the touch path, ms (default 40, the KinesTouch tablet's 'few dozens of ms'; 0 for a trajectory replay).")
_PRED = typer.Option(True, "--predict/--no-predict", help="Compensate the touch latency by prediction (004 eq. 6-7).")
_KPRED = typer.Option(None, "--k-pred", help="Fixed prediction gain of eq. 6 (paper: 8 at 60 Hz); default: derived from the latency.")
_SMOOTH = typer.Option(0.15, "--smoothing", help="Position smoothing of eq. 7 (the paper's alpha), (0, 1] (paper: 0.15).")
_OLD_ALPHA = typer.Option(None, "--alpha", hidden=True, help="Renamed --smoothing (an error naming the new option).")
_VALPHA = typer.Option(0.45, "--velocity-alpha", help="Velocity smoothing per touch sample, (0, 1] (paper: 0.45).")
_GAIN = typer.Option(None, "--gain", help="Device units per newton (default 4.5: a Falcon through CHAI3D, 004 Sec. 4.3).")
_SLEW = typer.Option(None, "--slew", help="Largest force change per axis, N/s (default 400).")
_FMAX = typer.Option(None, "--f-max", help="Per-axis force limit, N (default 8: the Falcon's largest force).")


def scenes_cmd() -> None:
    """List the built-in example scenes."""
    from surfhap.ff.scene import builtin_scene_names, builtin_scene_path

    for name in builtin_scene_names():
        desc = json.loads(builtin_scene_path(name).read_text(encoding="utf-8")).get("description", "")
        stdout().print(f"{name:<10} {desc}")


def simulate_cmd(
    scene: str = typer.Argument(..., help="Built-in scene name (see 'surfhap ff scenes') or scene JSON file."),
    trajectory: Optional[Path] = typer.Option(None, "--trajectory", help="Finger trajectory CSV (time s, x m, y m, load N) in content coordinates; default: 0.5 Hz strokes through the centre (a scene with GUI buttons: one push per button)."),
    out: Path = typer.Option(Path("ff-sim"), "--out", help="Output directory (NPZ, summary.json, figures)."),
    touch_rate: float = typer.Option(60.0, "--touch-rate", help="Touch report rate of the simulated tablet, Hz (paper: 60)."),
    mu: float = typer.Option(0.0, "--mu", help="Finger-screen Coulomb friction coefficient of the simulated finger (0 = none)."),
    touch_latency_ms: Optional[float] = _LAT, predict: bool = _PRED, k_pred: Optional[float] = _KPRED,
    smoothing: float = _SMOOTH, velocity_alpha: float = _VALPHA, gain: Optional[float] = _GAIN,
    slew: Optional[float] = _SLEW, f_max: Optional[float] = _FMAX, old_alpha: Optional[float] = _OLD_ALPHA,
    figures: bool = typer.Option(True, "--figures/--no-figures", help="Write PNG figures."),
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Simulate SCENE on a simulated device with a simulated finger: forces, screen motion,
    finger-screen relative sliding and effect switches."""
    import numpy as np

    from surfhap.ff.scene import load_scene
    from surfhap.sim.ff_device import SimDevice, SimFinger
    from surfhap.live.ff_loop import simulate_ff

    check_out(out, "--out", overwrite)
    if touch_latency_ms is None:
        touch_latency_ms = PAPER_LATENCY_MS
    if not 10.0 <= touch_rate <= 1000.0:
        raise ConfigError("must be within 10-1000 Hz", source="--touch-rate")
    if not 0.0 <= mu <= 3.0:
        raise ConfigError("must be within 0-3", source="--mu")
    dev = _device(gain, slew, f_max)
    sc = load_scene(scene, dev)
    if trajectory is not None:
        from surfhap.exchange.trajectory_csv import read_trajectory_csv

        tr = read_trajectory_csv(trajectory)
        if tr.duration > 600:
            raise ConfigError("longer than 600 s", source=str(trajectory), field="time")
    else:
        tr = _default_trajectory(sc)
    eng = _engine(sc, dev, predict, touch_latency_ms, k_pred, smoothing, velocity_alpha, old_alpha)
    res = simulate_ff(eng, SimFinger(tr, touch_rate=touch_rate, latency=touch_latency_ms * 1e-3, mu=mu), SimDevice(gain=dev.gain),
                      name=f"{sc.name} / {tr.name}")
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / "ff_simulation.npz", **{f.name: np.array(getattr(res, f.name), dtype=str if
                        f.name == "buttons" else None) for f in fields(res) if f.name != "name"})
    summary = res.summary()
    summary.update(error=None if eng.error is None else _one_line(eng.error),
                   scene=sc.source, trajectory=str(trajectory) if trajectory else tr.name, device=dev.name,
                   gain=dev.gain, touch_latency_ms=touch_latency_ms, predict=predict,
                   switch_log=[{"t_s": round(t, 4), "active": names} for t, names in res.switches()[:200]])
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    if figures:
        from surfhap.report.ff_figures import plot_ff_top_view

        res.plot().savefig(out / "ff_simulation.png", dpi=110)
        plot_ff_top_view(res, picture=sc.picture_array(), size=sc.size).savefig(out / "ff_top_view.png", dpi=110)
    fx, fy, fz = summary["force_abs_max_N"]
    report({**summary, "out": str(out)},
           f"{sc.name}: {summary['duration_s']:.1f} s, {summary['ticks']} ticks at {eng.rate:.0f} Hz; largest force "
           f"|Fx| {fx:.2f}, |Fy| {fy:.2f}, |Fz| {fz:.2f} N; sliding {summary['sliding_speed_rms_m_s'] * 1e3:.1f} mm/s "
           f"rms (finger {summary['finger_speed_rms_m_s'] * 1e3:.1f} mm/s); {summary['switches']} effect switches"
           + (f", {len(summary['button_presses'])} button presses" if res.buttons else "") + f" -> {out}", as_json)
    _exit_if_failed(eng.error)


def run_cmd(
    scene: str = typer.Argument(..., help="Built-in scene name or scene JSON file."),
    device: str = typer.Option("sim", "--device", help="sim | osc://HOST:PORT (a device bridge receiving /surfhap/ff/force) | haply://HOST:PORT (a Haply Inverse3 through its Inverse Service, e.g. haply://127.0.0.1:10001; --gain defaults to 1, the service takes newtons)."),
    device_silence_ms: float = typer.Option(20.0, "--device-silence-ms", help="haply device: no state from the service for this long ends the run (exit 3) once the force has ramped to zero (default 20 ms, the rig's fail-safe target)."),
    device_listen: str = typer.Option("127.0.0.1:9101", "--device-listen", help="HOST:PORT where the bridge sends /surfhap/ff/position (osc device)."),
    touch: str = typer.Option("osc://127.0.0.1:9100", "--touch", help="osc://HOST:PORT (listen for /surfhap/touch, screen coordinates) | web (the touch page) | trajectory:FILE.csv (finger in the world, as for simulate)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address of the touch page (--touch web)."),
    port: int = typer.Option(8766, "--port", help="TCP port of the touch page (--touch web)."),
    trajectory: Optional[Path] = typer.Option(None, "--trajectory", help="Replay this trajectory CSV as the touch source (same as --touch trajectory:FILE)."),
    feedback: Optional[str] = typer.Option(None, "--feedback", help="osc://HOST:PORT of the tablet: 60 Hz /surfhap/ff/screen, /offset, /force, and /button on GUI button presses."),
    duration: float = typer.Option(0.0, "--duration", help="Stop after this many seconds (0 = until Ctrl-C / SIGTERM)."),
    touch_latency_ms: Optional[float] = _LAT, predict: bool = _PRED, k_pred: Optional[float] = _KPRED,
    smoothing: float = _SMOOTH, velocity_alpha: float = _VALPHA, gain: Optional[float] = _GAIN,
    slew: Optional[float] = _SLEW, f_max: Optional[float] = _FMAX, old_alpha: Optional[float] = _OLD_ALPHA,
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log at INFO."),
    as_json: JsonOption = False,
) -> None:
    """Run SCENE live: a 1 kHz haptic thread driving the device and a 60 Hz position-feedback
    thread; Ctrl-C or SIGTERM ramps the force to zero, prints the stats and exits 130."""
    _require_extras(touch if trajectory is None else "trajectory:", device, feedback)
    from surfhap.ff.scene import load_scene
    from surfhap.live.ff_devices import OscDeviceBackend, SimDeviceBackend
    from surfhap.live.ff_loop import FFLoop, OscFeedback, WorldTouchAdapter
    from surfhap.live.logfilter import configure_logging
    from surfhap.live.netaddr import parse_host_port, parse_url

    configure_logging(verbose)  # rate-limited: a flood of rejected touches is one line per kind per second
    if duration < 0 or duration > 86400:
        raise ConfigError("must be within 0-86400 s", source="--duration")
    haply = device.startswith("haply://")
    dev = _device(1.0 if gain is None and haply else gain, slew, f_max)
    sc = load_scene(scene, dev)
    if trajectory is not None:
        touch = f"trajectory:{trajectory}"
    if touch_latency_ms is None:  # a replay arrives on time; a tablet has the paper's latency
        touch_latency_ms = 0.0 if touch.startswith("trajectory:") else PAPER_LATENCY_MS
    if device == "sim":
        from surfhap.sim.ff_device import SimDevice

        backend = SimDeviceBackend(SimDevice(gain=dev.gain), dev.gain)
    elif haply:
        from surfhap.live.ff_haply import HaplyDevice

        if not 1.0 <= device_silence_ms <= 1000.0:
            raise ConfigError("must be within 1-1000 ms", source="--device-silence-ms")
        backend = HaplyDevice(*parse_url(device, "--device", "haply"), dev.gain, silence=device_silence_ms * 1e-3)
    else:  # the bridge's address: its own names (host and port are the touch page's)
        bridge_host, bridge_port = parse_url(device, "--device")
        backend = OscDeviceBackend(bridge_host, bridge_port, dev.gain,
                                   listen=parse_host_port(device_listen, "--device-listen", listen=True))
    fb = None if feedback is None else OscFeedback(*parse_url(feedback, "--feedback"))
    eng = _engine(sc, dev, predict, touch_latency_ms, k_pred, smoothing, velocity_alpha, old_alpha)
    if fb is not None:
        fb.engine = eng  # button press / release events
    loop = FFLoop(eng, backend, feedback=fb)
    replay_done = None  # a replay that ends (without --duration) ends the run
    if touch.startswith("trajectory:"):
        from surfhap.exchange.trajectory_csv import read_trajectory_csv
        from surfhap.runtime.sources import TrajectorySource

        source = TrajectorySource(WorldTouchAdapter(loop, backend), read_trajectory_csv(touch[len("trajectory:"):]),
                                  loop=duration > 0, wall_clock=True)
        replay_done = source.done if duration == 0 else None
    elif touch.startswith("osc://"):
        from surfhap.live.sources import OscTouchSource, TouchSpace

        touch_host, touch_port = parse_url(touch, "--touch", listen=True)
        w, h = sc.size
        source = OscTouchSource(loop, host=touch_host, port=touch_port, space=TouchSpace(width=w, height=h))
    elif touch == "web":
        source = _WebSource(sc, loop, dev, host, port)
    else:
        raise ConfigError("expected osc://HOST:PORT, web or trajectory:FILE", source="--touch")
    guard = StopSignals(on_stop=loop.request_stop)  # Ctrl-C and SIGTERM: the loop ramps the force to zero
    with guard:
        try:
            try:
                source.start()
            except OSError as exc:
                raise ConfigError(f"cannot listen ({exc.strerror or exc})", source="--touch") from None
            try:
                loop.start()
            except OSError as exc:
                source.stop()
                raise ConfigError(f"cannot open the device link ({exc.strerror or exc})", source="--device") from None
            shown = f"{touch.rsplit(':', 1)[0]}:{source.port}" if touch.startswith("osc://") else touch  # the port bound
            stderr().print(f"surfhap ff: {sc.name} on {backend.name} at {loop.rate:.0f} Hz; touch {shown}"
                           f"{'' if backend.name != 'osc' else f'; positions on udp port {backend.listen_port}'}"
                           " (Ctrl-C stops)")
            end = time.monotonic() + duration if duration > 0 else None
            while not loop.done.is_set():
                if end is not None and time.monotonic() >= end:
                    loop.request_stop()
                    end = None
                if replay_done is not None and replay_done.is_set():
                    loop.request_stop()
                if guard.wait(0.05):  # on_stop requested the ramp: wait for the loop to finish it
                    loop.done.wait(0.05)
        finally:
            source.stop()
            loop.stop()
    st = loop.stats()
    st["scene"] = sc.name
    pe = st["period_error_ms"]
    report(st, [f"{sc.name} on {backend.name}: {st['ticks']} ticks at {st['rate_hz']:.0f} Hz, {st['missed']} missed "
                f"({st['missed'] / max(st['ticks'], 1):.1%}); period error p99 {pe['p99']:.2f} ms, max {pe['max']:.2f} ms",
                f"touches: {st['touches_received']} received, {st['touches_dropped']} dropped, {st['touches_stale']} "
                f"stale, {st['touches_rejected']} rejected" + (f"; failed: {st['error']}" if st["error"] else "")],
           as_json)
    _exit_if_failed(loop.error)
    guard.finish("the force ramped to zero, status above")


def _one_line(error: BaseException) -> str:
    """``Type: message`` on one line, at most 300 characters (status lines and summaries)."""
    return " ".join(f"{type(error).__name__}: {error}".split())[:300]


def _exit_if_failed(error: BaseException | None) -> None:
    """A force loop that raised has ramped down through the safety stage: one line, exit 3
    (as ``play`` does for a failed backend). ``ff run`` and ``ff simulate`` end the same way."""
    if error is not None:
        fail(f"force-feedback loop failed ({_one_line(error)}); the force was ramped to zero", 3)


def _require_extras(touch: str, device: str, feedback: Optional[str]) -> None:
    """Before anything starts: the modules the chosen touch source, device and feedback need
    (a missing one is one line naming the extra, exit 2, instead of a web process that never comes up)."""
    if touch == "web":
        require_modules("fastapi", "starlette", "uvicorn")
    if touch.startswith("osc://") or device.startswith("osc://") or feedback is not None:
        require_modules("pythonosc")
    if device.startswith("haply://"):
        require_modules("websockets")


class _WebSource:
    """The touch page (its own process) feeding the loop; the page's trace shows |F| and its
    force-feedback panel the device position, the force vector, the active effects and the
    pressed button."""

    def __init__(self, scene, loop, dev, host: str, port: int):
        from surfhap.web.ff import build_ff_session

        if not 1 <= port <= 65535:
            raise ConfigError("must be within 1-65535", source="--port")
        self.session = build_ff_session(scene, loop, max(dev.f_max))
        self.host, self.port = host, port
        self.loop = loop
        self.server = None
        record = self.session.engine.record
        osc = loop.feedback

        def feedback(t, px, py, pz, dx, dy, fx, fy, fz):
            record(t, px, py, pz, fx, fy, fz)
            if osc is not None:
                osc(t, px, py, pz, dx, dy, fx, fy, fz)

        loop.feedback = feedback

    def start(self) -> None:
        from surfhap.live.config import ServerConfig
        from surfhap.web.process import WebProcess

        self.server = WebProcess(self.session, ServerConfig(host=self.host, port=self.port)).start()
        stdout().print(f"touch page: http://{self.host}:{self.port}/")

    def stop(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None


def register(app: typer.Typer) -> None:
    ff_app.command("scenes")(scenes_cmd)
    ff_app.command("simulate")(simulate_cmd)
    ff_app.command("run")(run_cmd)
    from surfhap.cli.ff_bridge import bridge_check_cmd

    ff_app.command("bridge-check")(bridge_check_cmd)
    app.add_typer(ff_app, name="ff")
