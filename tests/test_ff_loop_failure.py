"""A failure inside the force-feedback loop (issue 17 item 2): the output ramps down through
the safety stage instead of jumping to 0 N, and ``ff run`` exits 3 with one line."""

import json
import threading

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.trajectory_csv import write_trajectory_csv
from surfhap.ff import FALCON, Effect, FFEngine, Sliding, Stiffness
from surfhap.ff import scene as ff_scene
from surfhap.live.ff_devices import SimDeviceBackend
from surfhap.live.ff_loop import FFLoop
from surfhap.runtime.clock import SimClock
from surfhap.render.kinematics import TouchPredictor
from surfhap.models.trajectory import Trajectory
from surfhap.sim.ff_device import SimDevice


class Failing(Effect):
    """A Python effect (evaluated in Python each touched tick) with the terms of the built-in
    ``inner`` that raises ``message`` from its call number ``after + 1`` on."""

    def __init__(self, inner: Effect, after: int, message: str):
        self.inner, self.after, self.message, self.calls = inner, after, message, 0
        self.name, self.vibration = inner.name, inner.vibration
        super().__init__()

    def terms(self, s):
        self.calls += 1
        if self.calls > self.after:
            raise RuntimeError(self.message)
        return self.inner.terms(s)


def failing_sliding(monkeypatch, after: int) -> None:
    """Scenes loaded from now on have their Sliding effect raise after ``after`` calls."""
    build = ff_scene.build_effects
    monkeypatch.setattr(ff_scene, "build_effects", lambda *a: [
        Failing(e, after, "injected\nfailure") if isinstance(e, Sliding) else e for e in build(*a)])


class Recording(SimDeviceBackend):
    """The simulated device, keeping every force written."""

    def __init__(self):
        super().__init__(SimDevice(gain=FALCON.gain), FALCON.gain)
        self.log = []
        self.first_touch = threading.Event()

    def write(self, force, t):
        self.log.append(np.array(force, dtype=float))
        super().write(force, t)


def test_exception_in_an_effect_ramps_down_in_the_running_loop():
    """The haptic thread: an effect raises while the screen is held at the weight plus a
    pressing finger; every written change stays within the slew limit, the loop ends at 0 N
    and keeps the error."""
    eng = FFEngine([Failing(Stiffness(300.0), 200, "injected")], FALCON, TouchPredictor(), touch_latency=0.0)
    be = Recording()
    loop = FFLoop(eng, be)
    loop.start()
    try:
        for _ in range(2000):  # touch every 5 ms until the effect fails and the loop ends
            loop.push_touch(0, 0.05, 0.05, 2.0)
            if loop.done.wait(0.005):
                break
        assert loop.done.wait(30.0)
    finally:
        loop.stop()
    assert isinstance(loop.error, RuntimeError)
    f = np.array(be.log)
    assert np.abs(f).max() > 1.0  # it was holding a force when the effect failed
    assert np.abs(np.diff(f, axis=0)).max() <= FALCON.slew / FALCON_RATE + 1e-9
    assert np.all(f[-1] == 0.0)
    assert loop.stats()["error"] is not None


FALCON_RATE = 1000.0


def test_ff_run_exits_3_with_one_line_when_the_loop_fails(tmp_path, capsys, monkeypatch):
    t = np.arange(0.0, 1.0, 1.0 / 120)
    csv = tmp_path / "t.csv"
    write_trajectory_csv(Trajectory(t, 0.1 + 0.03 * np.sin(np.pi * t), np.full(t.size, 0.07), np.ones(t.size)), csv)

    failing_sliding(monkeypatch, 0)
    code = main(["ff", "run", "follow", "--json", "--device", "sim", "--trajectory", str(csv)])
    out = capsys.readouterr()
    assert code == 3, out.err
    start = out.err.index("(Ctrl-C stops)") + len("(Ctrl-C stops)")  # the start line (wrapped by the console)
    lines = [ln for ln in out.err[start:].splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: force-feedback loop failed"), out.err
    assert "Traceback" not in out.err
    st = json.loads(out.out.strip().splitlines()[-1])
    assert "injected" in st["error"] and st["safety"]["stopped"] >= 1


def test_ff_simulate_exits_3_with_one_line_when_an_effect_fails(tmp_path, capsys, monkeypatch):
    """The offline simulation ends like the live loop: the files are written (the force ramped
    down through the safety stage, never a jump), the summary keeps the error, one line, exit 3."""
    failing_sliding(monkeypatch, 300)
    out_dir = tmp_path / "sim"
    code = main(["ff", "simulate", "follow", "--out", str(out_dir), "--no-figures"])
    out = capsys.readouterr()
    assert code == 3, out.err
    lines = [ln for ln in out.err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: force-feedback loop failed"), out.err
    assert "Traceback" not in out.err
    summary = json.loads((out_dir / "summary.json").read_text())
    assert "injected failure" in summary["error"]
    with np.load(out_dir / "ff_simulation.npz") as z:
        f = z["force"]
    assert np.abs(f).max() > 0.1  # it was rendering a force when the effect failed
    assert np.abs(np.diff(f[:, :2], axis=0)).max() <= FALCON.slew / FALCON_RATE + 1e-9  # lateral: slew-limited
    assert np.all(f[-1, :2] == 0.0)


def _fail_in_loop(where: str):
    """The buttons scene held by the simulated device on a simulated clock for 0.5 s, then a
    failure ``where`` ('drain': the touch drain raises; 'tick': the engine's tick raises after
    its safety stage took the position). Returns the loop and the vertical speed and force per tick."""
    from surfhap.ff.scene import load_scene

    sc = load_scene("buttons", FALCON)
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), rate=FALCON_RATE)
    dev = SimDevice(rate=FALCON_RATE, gain=FALCON.gain)
    be = SimDeviceBackend(dev, FALCON.gain)
    clock = SimClock()
    loop = FFLoop(eng, be, clock=clock)
    be.start()

    def broken_drain():
        raise RuntimeError("touch ring broken")

    def tick_broken_after_the_safety_stage(t, px, py, pz, t_pos):
        eng.observe(t, t_pos, px, py, pz)  # the safety stage took this tick's position
        raise RuntimeError("tick broken after the safety stage")

    vz, fz = [], []
    for k in range(6000):
        clock.t = k / FALCON_RATE
        if k == 500 and where == "drain":
            loop._drain = broken_drain
        elif k == 500:
            eng.tick = tick_broken_after_the_safety_stage
        go = loop.tick_once(clock.t)
        vz.append(dev.v[2])
        fz.append(float(eng.out[2]))
        if not go:
            break
    return loop, np.array(vz), np.array(fz)


@pytest.mark.parametrize("where", ["drain", "tick"])
def test_a_failure_anywhere_in_the_tick_lands_the_tablet(where):
    """A failure in the touch drain or in the engine's tick (after its safety stage took the
    position) is a stop like any other: the device is still read, the weight compensation is
    lowered over >= 1 s (the tablet sinks no faster than its weight against the landing damping),
    every change is slew-limited, and the loop ends at 0 N with the error kept."""
    from surfhap.ff.params import GRAVITY

    loop, vz, fz = _fail_in_loop(where)
    assert loop.error is not None and "broken" in str(loop.error)
    after = slice(500, None)
    assert fz[500:500 + int(FALCON_RATE)].min() > 0.0, "the compensation was dropped within 1 s"
    terminal = FALCON.moving_mass * GRAVITY / 20.0
    assert -vz[after].min() <= terminal, f"fell at {-vz[after].min():.2f} m/s"
    assert np.abs(np.diff(fz)).max() <= FALCON.slew / FALCON_RATE + 1e-9
    assert fz[-1] == 0.0
