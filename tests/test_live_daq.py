"""The NI-DAQmx analog output (``--output daq:Dev1/ao0``) against a recorded stand-in of the
``nidaqmx`` calls (tests/live_support/fake_nidaqmx.py): no NI driver or device here, never
run on hardware. Every call the backend makes is also checked against the signatures of the
real installed ``nidaqmx`` package (skipped where it is not installed, except in CI).
"""

from __future__ import annotations

import importlib
import inspect
import math
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent / "live_support"))

import fake_nidaqmx as fake  # noqa: E402

from surfhap.cli import main  # noqa: E402
from surfhap.errors import ConfigError  # noqa: E402
from surfhap.exchange.materials import load_material  # noqa: E402
from surfhap.live.audit import audit_drive  # noqa: E402
from surfhap.live.backends.output import DaqOutput, OutputOptions, open_backend  # noqa: E402
from surfhap.live.engine import LiveEngine  # noqa: E402
from surfhap.live.engine_config import EngineConfig  # noqa: E402
from surfhap.render.chain import ChainConfig, TextureChain  # noqa: E402
from surfhap.render.safety import SafetyLimits  # noqa: E402

IN_CI = os.environ.get("CI", "").lower() == "true"
RATE, GAIN = 20000, 250.0
GUARD = 60.0  # s: a failure guard for waits on a loaded machine, never a timing assertion


def real_nidaqmx():
    try:
        return importlib.import_module("nidaqmx")
    except ImportError as exc:
        if IN_CI:
            pytest.fail(f"CI installs surfhap[daq]: {exc}")
        pytest.skip(f"nidaqmx not installed ({exc})")


class Run:
    """An engine rendering cork into the DAQ backend on the stand-in; ``rendered`` and
    ``stamps`` keep every block the engine returned and the time it was stamped with."""

    def __init__(self, monkeypatch, stall_timeout=1.0, limits=None, **device):
        self.dev = fake.install(monkeypatch, fake.FakeDevice(**device))
        cfg = ChainConfig(drive_rate=RATE, **({} if limits is None else {"limits": limits}))
        self.engine = eng = LiveEngine(TextureChain(load_material("cork"), cfg), EngineConfig())
        eng.warm_up()  # as a session does before its backend starts: kernels loaded
        self.rendered, self.stamps, self.touches = [], [], []
        render = eng.render

        def recording_render(frames, now=None):
            out = render(frames, now)
            self.rendered.append(out.copy())
            self.stamps.append(now)
            return out

        eng.render = recording_render
        self.backend = open_backend(DaqOutput("Dev1/ao0"), OutputOptions(amp_gain=GAIN))
        self.backend.stall_timeout = stall_timeout

    def stroke(self, seconds: float = GUARD, until=None) -> None:
        """Touches at 200 Hz (a finger sliding back and forth) for ``seconds`` or until ``until()``."""
        t0 = time.perf_counter()
        while (t := time.perf_counter() - t0) < seconds and not (until is not None and until()):
            self.touches.append(time.perf_counter())  # the engine's arrival stamp (the engine clock)
            self.engine.push_touch(1, 0.02 + 0.04 * abs((t * 2.0) % 2.0 - 1.0), 0.03, 0.6, t_event=t,
                                   t_arrival=self.touches[-1])
            time.sleep(0.005)

    def stroking(self, until) -> threading.Thread:
        """A finger stroking in its own thread until ``until()`` (or the failure guard)."""
        th = threading.Thread(target=self.stroke, kwargs={"until": until})
        th.start()
        return th

    def wait(self, cond) -> None:
        end = time.monotonic() + GUARD
        while not cond() and time.monotonic() < end:
            time.sleep(0.005)
        assert cond(), (self.engine.status(), self.dev.n_writes, len(self.touches),
                        [float(np.abs(w).max()) for w in self.dev.writes[::50]])

    def generated(self) -> np.ndarray:
        """Volts at the amplifier: every sample the device generated, runs in order."""
        return GAIN * np.concatenate(self.dev.runs)


def test_the_task_is_continuous_without_regeneration_and_its_buffer_is_sized_from_the_block(monkeypatch):
    r = Run(monkeypatch)
    r.backend.start(r.engine)
    r.backend.stop()
    block = r.engine.block_frames
    assert block == 20  # 1 ms blocks at 20 kHz
    buf = block * 5  # the paced outputs' 5 ms of buffer, in whole blocks
    calls = r.dev.calls
    assert ("Timing.cfg_samp_clk_timing", (RATE,), {"sample_mode": fake.AcquisitionType.CONTINUOUS,
                                                     "samps_per_chan": buf}) in calls
    assert ("OutStream.regen_mode=", (fake.RegenerationMode.DONT_ALLOW_REGENERATION,), {}) in calls
    assert ("OutStream.output_buf_size=", (buf,), {}) in calls
    assert ("AOChannel.ao_idle_output_behavior=", (fake.AOIdleOutputBehavior.ZERO_VOLTS,), {}) in calls
    v_ao = r.engine.v_max / GAIN
    name, args, kw = next(c for c in calls if c[0] == "AOChannelCollection.add_ao_voltage_chan")
    assert args == ("Dev1/ao0",) and kw == {"min_val": -v_ao, "max_val": v_ao}
    writer = next(c for c in calls if c[0] == "AnalogSingleChannelWriter.__init__")
    assert writer[2] == {"auto_start": False}
    names = r.dev.names()
    # a buffer of 0 V is written before the start; the task is stopped, then closed
    first_write = names.index("AnalogSingleChannelWriter.write_many_sample")
    assert first_write < names.index("Task.start") and r.dev.writes[0].tolist() == [0.0] * buf
    assert names[-2:] == ["Task.stop", "Task.close"]
    assert r.backend.info()["buffer_frames"] == buf


def test_the_samples_written_are_the_safety_stage_output_and_the_watchdog_holds_at_the_dac(monkeypatch):
    r = Run(monkeypatch)
    r.backend.start(r.engine)
    r.stroke(until=lambda: len(r.rendered) > 300 and max(np.abs(b).max() for b in r.rendered[-50:]) > 50)
    t_last = r.touches[-1]
    r.wait(lambda: len(r.stamps) > 0 and r.stamps[-1] > t_last + 0.1)  # the watchdog's 55 ms and more
    r.backend.stop()
    eng = r.engine
    assert eng.counters["errors"] == 0 and eng.counters["underruns"] == 0 and eng.failure is None
    written = GAIN * np.concatenate(r.dev.writes[1:])  # after the buffer of 0 V
    rendered = np.concatenate(r.rendered)
    assert written.shape == rendered.shape
    np.testing.assert_allclose(written, rendered, rtol=1e-12, atol=1e-12)
    assert np.abs(rendered).max() > 50  # it drove the display
    # what the device generated keeps the limits; each sample's touch age is taken at the
    # moment it leaves the DAC (the block's stamp: now plus the samples queued before it)
    sent = np.concatenate([t + np.arange(b.shape[0]) / RATE for t, b in zip(r.stamps, r.rendered)])
    touches = np.array(r.touches)
    last = np.searchsorted(touches, sent, side="right") - 1
    age = np.where(last >= 0, sent - touches[np.maximum(last, 0)], np.inf)
    lim = eng.renderer.safety.limits
    a = audit_drive(rendered, RATE, lim, touch_age=age)
    assert a["violations"] == 0, a
    assert not np.any(rendered[sent > t_last + lim.watchdog_timeout + lim.watchdog_ramp + 1e-9])
    gen = r.generated()
    np.testing.assert_array_equal(gen[-1:], [0.0])


def test_stop_ramps_to_zero_and_the_device_generates_the_ramp_before_the_task_stops(monkeypatch):
    r = Run(monkeypatch)
    r.backend.start(r.engine)
    loud = lambda: len(r.rendered) > 100 and np.abs(r.rendered[-1]).max() > 50  # noqa: E731
    stroke = r.stroking(until=lambda: r.engine.stopped)
    r.wait(loud)
    r.backend.stop()  # what Ctrl-C and SIGTERM do (session.stop), while the finger still slides
    stroke.join()
    assert r.engine.stopped and r.engine.failure is None
    assert r.dev.held == [0.0] and len(r.dev.runs) == 1
    # the device generated the buffer of 0 V, then what the engine rendered, up to and past its
    # last nonzero sample (the end of the stop ramp) before the task was stopped: nothing cut
    gen = r.generated()
    sent = np.concatenate([np.zeros(r.backend.buffer_frames), *r.rendered])
    np.testing.assert_allclose(gen, sent[: gen.size], rtol=1e-12, atol=1e-12)
    assert gen.size > np.flatnonzero(sent)[-1]


def test_an_underrun_is_counted_reported_and_the_output_restarts_from_zero(monkeypatch):
    # a rise limit of 10 V per sample (0 to v_max in 25 samples), so a step would show
    # the buffer runs empty while the output drives (> 50 V), after the first 100 writes
    loud = lambda k, data: k > 100 and np.abs(data).max() * GAIN > 50  # noqa: E731
    r = Run(monkeypatch, underrun_if=loud, limits=SafetyLimits(rise_rate=2e5))
    r.backend.start(r.engine)
    done = lambda: bool(r.dev.underrun_writes) and r.dev.n_writes > r.dev.underrun_writes[0] + 200  # noqa: E731
    stroke = r.stroking(until=done)
    r.wait(done)
    stroke.join()
    r.backend.stop()
    eng = r.engine
    assert eng.counters["underruns"] == 1 and r.backend.underruns == 1 and eng.failure is None
    assert eng.status()["counters"]["underruns"] == 1 and r.backend.info()["underruns"] == 1
    names = r.dev.names()
    w = r.dev.underrun_writes[0]
    k = [i for i, n in enumerate(names) if n == "AnalogSingleChannelWriter.write_many_sample"][w - 1]
    assert names[k + 1 : k + 4] == ["Task.stop", "AnalogSingleChannelWriter.write_many_sample", "Task.start"]
    assert not np.any(r.dev.writes[w])  # the restart's buffer is 0 V
    assert len(r.dev.runs) == 2
    # across the restart the rise limit holds from 0 V: the device idled at 0 V, then the
    # buffer of 0 V, then the engine's output rises from zero (no step to the old level)
    after = GAIN * r.dev.runs[1]
    assert audit_drive(after, RATE, eng.renderer.safety.limits, prev=0.0)["violations"] == 0
    assert np.abs(after).max() > 50  # and it drove again


def test_a_hung_write_halts_the_engine_and_aborts_the_task(monkeypatch):
    r = Run(monkeypatch, stall_timeout=0.1, hang_at=200)
    r.backend.start(r.engine)
    stroke = r.stroking(until=lambda: r.engine.failure is not None)
    r.wait(lambda: r.engine.failure is not None)
    stroke.join()
    r.backend.stop()
    eng = r.engine
    assert "daq output stalled" in eng.failure and eng.halted
    assert ("Task.control", (fake.TaskMode.TASK_ABORT,), {}) in r.dev.calls
    assert r.dev.names()[-1] == "Task.close" and r.dev.held[-1] == 0.0
    assert not np.any(eng.render(eng.block_frames))  # 0 V from then on


def test_a_device_without_idle_at_zero_volts_is_used_and_said(monkeypatch, caplog):
    r = Run(monkeypatch, idle_zero=False)
    r.backend.start(r.engine)
    r.backend.stop()
    assert r.backend.info()["idle_zero"] is False
    assert "holds its last sample" in caplog.text


@pytest.mark.parametrize("device,message", [
    ({"driver": False}, "no NI-DAQmx driver"),
    ({"devices": ("Dev2",)}, "cannot open DAQ channel Dev1/ao0"),
    ({"max_rate": 10000}, "cannot open DAQ channel Dev1/ao0 at 20000 Hz"),
])
def test_a_missing_driver_or_device_is_one_line_and_exit_2(monkeypatch, capsys, device, message):
    fake.install(monkeypatch, fake.FakeDevice(**device))
    code = main(["play", "cork", "--output", "daq:Dev1/ao0", "--scan", "speed=0.1,load=0.5,duration=0.2"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert message in err and "--output" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_a_simulated_clock_cannot_drive_the_daq(monkeypatch, capsys, tmp_path):
    dev = fake.install(monkeypatch, fake.FakeDevice())
    traj = tmp_path / "t.csv"
    traj.write_text("time,x,y,load\n0,0.02,0.03,0.5\n0.1,0.03,0.03,0.5\n")
    code = main(["play", "cork", "--output", "daq:Dev1/ao0", "--clock", "sim", "--trajectory", str(traj)])
    err = capsys.readouterr().err
    assert code == 2 and "--clock" in err and "Traceback" not in err
    assert dev.calls == []  # the device was never opened


def test_without_nidaqmx_the_output_says_what_to_install(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "nidaqmx", None)  # import nidaqmx raises ImportError
    code = main(["play", "cork", "--output", "daq:Dev1/ao0"])
    err = capsys.readouterr().err
    assert code == 2 and "--output" in err and "surfhap[daq]" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_with_the_real_nidaqmx_and_no_driver_the_command_says_so(capsys):
    real_nidaqmx()
    code = main(["play", "cork", "--output", "daq:Dev1/ao0"])
    err = capsys.readouterr().err
    assert code == 2 and "--output" in err and "NI-DAQmx" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("text,ok", [("daq:Dev1/ao0", True), ("daq:cDAQ1Mod2/ao3", True), ("daq:Dev1", False),
                                     ("daq:Dev1/ai0", False), ("daq:", False)])
def test_the_output_text(text, ok):
    from surfhap.cli._output import parse_output

    if ok:
        assert parse_output(text) == DaqOutput(text[4:])
    else:
        with pytest.raises(ConfigError, match="--output"):
            parse_output(text)


def test_an_amplifier_gain_too_low_for_the_ao_range_is_refused(monkeypatch):
    fake.install(monkeypatch, fake.FakeDevice())
    eng = LiveEngine(TextureChain(load_material("cork"), ChainConfig(drive_rate=RATE)), EngineConfig())
    be = open_backend(DaqOutput("Dev1/ao0"), OutputOptions(amp_gain=eng.v_max / 10.5))
    with pytest.raises(ConfigError, match="--amp-gain"):
        be.start(eng)


def test_every_call_exists_in_the_real_nidaqmx_with_a_compatible_signature(monkeypatch):
    """The stand-in cannot drift from the API: each recorded call binds to the real method's
    signature (a property set to a real property with a setter), the enums and error classes
    carry the real names and values, and the underrun codes are NI's."""
    real = real_nidaqmx()
    from nidaqmx import constants, error_codes, errors

    calls = []
    for device in ({"underrun_at": {30}}, {"hang_at": 30}):  # every path: start, write, underrun, abort, stop
        r = Run(monkeypatch, stall_timeout=0.1, **device)
        r.backend.start(r.engine)
        r.wait(lambda: r.dev.n_writes > 40 or r.engine.failure is not None)
        r.backend.stop()
        calls += r.dev.calls
    seen = set()
    for name, args, kwargs in calls:
        cls_name, member = name.split(".", 1)
        mod, _, cls = fake.REAL_CLASS[cls_name].rpartition(".")
        real_cls = getattr(importlib.import_module(mod), cls)
        attr = inspect.getattr_static(real_cls, member.rstrip("="))
        if member.endswith("="):
            assert isinstance(attr, property) and attr.fset is not None, name
        elif isinstance(attr, property):
            assert attr.fget is not None and not args and not kwargs, name
        else:
            inspect.signature(attr).bind(object(), *args, **kwargs)  # raises TypeError on a mismatch
        for a in [*args, *kwargs.values()]:
            if isinstance(a, fake.enum.Enum):
                assert getattr(constants, type(a).__name__)[a.name].value == a.value, a
        seen.add(name)
    assert {"Task.control", "Task.start", "Task.stop", "Task.close", "OutStream.regen_mode=",
            "AnalogSingleChannelWriter.write_many_sample"} <= seen
    assert real.Task is importlib.import_module("nidaqmx.task").Task
    for e in fake.ENUMS:
        assert {m.name: m.value for m in e} == {m.name: m.value for m in getattr(constants, e.__name__)}
    for e in fake.ERRORS:
        r_e = getattr(errors, e.__name__)
        assert [b.__name__ for b in r_e.__mro__[:-2]] == [b.__name__ for b in e.__mro__[:-2]]
        assert list(inspect.signature(r_e.__init__).parameters) == list(inspect.signature(e.__init__).parameters)
    assert isinstance(inspect.getattr_static(errors.DaqError, "error_code"), property)
    from surfhap.live.backends.daq import UNDERRUN_CODES

    codes = {m.value for m in error_codes.DAQmxErrors}
    assert UNDERRUN_CODES <= codes
    assert error_codes.DAQmxErrors.GEN_STOPPED_TO_PREVENT_REGEN_OF_OLD_SAMPLES.value == fake.REGEN_STOPPED
    for code in (fake.NOT_YET_WRITTEN, fake.ABORTED, fake.NO_DEVICE, fake.INVALID_VALUE):
        assert code in codes
    assert math.isclose(inspect.signature(real.task.collections.AOChannelCollection.add_ao_voltage_chan)
                        .parameters["max_val"].default, 10.0)  # AO_RANGE: NI's default range
