"""A recorded stand-in of the ``nidaqmx`` calls of the DAQ backend (no NI driver here).

:func:`install` puts the modules ``nidaqmx``, ``nidaqmx.constants``, ``nidaqmx.errors`` and
``nidaqmx.stream_writers`` into ``sys.modules`` (through pytest's ``monkeypatch``), backed by a
:class:`FakeDevice`: one AO channel whose hardware generates samples in real time at the
configured rate from a host buffer of ``output_buf_size`` samples. A write blocks until the
buffer has room (as NI's does, up to its timeout); the device never underflows by itself (a
late writer only pauses it), so the tests stay deterministic on a loaded machine; an underrun,
a hung write or a missing driver is scripted.

Every call is recorded in ``device.calls`` as ``(Class.member, args, kwargs)`` named after the
real nidaqmx class it stands for (``Task``, ``AOChannelCollection``, ``AOChannel``, ``Timing``,
``OutStream``, ``AnalogSingleChannelWriter``); a property set is ``(Class.member=, (value,), {})``
and a get ``(Class.member, (), {})``. ``tests/test_live_daq.py`` checks each one against the real
package's signatures, so this stand-in cannot drift from the API. The enums carry the real
names and values (checked there too).
"""

from __future__ import annotations

import enum
import functools
import sys
import threading
import time
import types

import numpy as np

REAL_CLASS = {  # the recorded class names -> where the real class lives in nidaqmx
    "Task": "nidaqmx.task.Task",
    "AOChannelCollection": "nidaqmx.task.collections.AOChannelCollection",
    "AOChannel": "nidaqmx.task.channels.AOChannel",
    "Timing": "nidaqmx.task.Timing",
    "OutStream": "nidaqmx.task.OutStream",
    "AnalogSingleChannelWriter": "nidaqmx.stream_writers.AnalogSingleChannelWriter",
}


# ---------------------------------------------------------------- nidaqmx.constants
class AcquisitionType(enum.Enum):
    FINITE = 10178
    CONTINUOUS = 10123
    HW_TIMED_SINGLE_POINT = 12522


class RegenerationMode(enum.Enum):
    ALLOW_REGENERATION = 10097
    DONT_ALLOW_REGENERATION = 10158


class AOIdleOutputBehavior(enum.Enum):
    ZERO_VOLTS = 12526
    HIGH_IMPEDANCE = 12527
    MAINTAIN_EXISTING_VALUE = 12528


class TaskMode(enum.Enum):
    TASK_START = 0
    TASK_STOP = 1
    TASK_VERIFY = 2
    TASK_COMMIT = 3
    TASK_RESERVE = 4
    TASK_UNRESERVE = 5
    TASK_ABORT = 6


ENUMS = (AcquisitionType, RegenerationMode, AOIdleOutputBehavior, TaskMode)


# ---------------------------------------------------------------- nidaqmx.errors
class Error(Exception):
    pass


class DaqNotFoundError(Error):
    pass


class DaqError(Error):
    def __init__(self, message, error_code, task_name=""):
        super().__init__(f"{message}\nStatus Code: {error_code}")
        self._error_code = int(error_code)

    @property
    def error_code(self):
        return self._error_code


class DaqWriteError(DaqError):
    def __init__(self, message, error_code, samps_per_chan_written, task_name=""):
        super().__init__(message, error_code, task_name)
        self.samps_per_chan_written = samps_per_chan_written


ERRORS = (Error, DaqNotFoundError, DaqError, DaqWriteError)
REGEN_STOPPED = -200290  # DAQmxErrors.GEN_STOPPED_TO_PREVENT_REGEN_OF_OLD_SAMPLES
NOT_YET_WRITTEN = -200292  # DAQmxErrors.SAMPLES_CAN_NOT_YET_BE_WRITTEN (a write timed out)
ABORTED = -201452  # DAQmxErrors.OPERATION_ABORTED
NO_DEVICE = -200220  # DAQmxErrors.INVALID_DEVICE_ID
INVALID_VALUE = -200077  # DAQmxErrors.INVALID_ATTRIBUTE_VALUE


# ---------------------------------------------------------------- the device and its task
def recorded(name):
    """Record the call exactly as the backend made it, then run the stand-in."""
    def deco(f):
        @functools.wraps(f)
        def call(self, *args, **kwargs):
            self._dev.record(name, *args, **kwargs)
            return f(self, *args, **kwargs)
        return call
    return deco


class FakeDevice:
    """``driver``: False -> ``Task()`` raises DaqNotFoundError. ``idle_zero``: the channel
    supports idling at 0 V. ``underrun_at``: write numbers (1-based, the prefill counts) that
    raise the regeneration underrun; ``underrun_if(k, data)``: the first write it is true for
    does too (``underrun_writes`` lists them). ``hang_at``: a write number that blocks until the task is
    aborted. ``devices``: the device names that exist; ``max_rate``: its fastest sample clock (the
    task refuses a faster one when it starts, as NI's commits the timing then)."""

    def __init__(self, driver=True, idle_zero=True, underrun_at=(), underrun_if=None, hang_at=None,
                 devices=("Dev1",), max_rate=1e6):
        self.driver, self.idle_zero = driver, idle_zero
        self.underrun_at, self.underrun_if, self.hang_at, self.devices = set(underrun_at), underrun_if, hang_at, tuple(devices)
        self.underrun_writes: list = []
        self.max_rate = max_rate
        self.calls: list = []
        self.writes: list = []  # every array written, in order (AO volts)
        self.runs: list = []  # the samples each run of the task generated, AO volts
        self.held: list = []  # the value the channel held after each run ended
        self.lock = threading.Lock()
        self.aborted = threading.Event()
        self.rate = 0.0
        self.buf = 0
        self.idle = None
        self.n_writes = 0
        self.running = False
        self.task_alive = False
        self._pending: list = []  # samples of the current run, written
        self._generated = 0
        self._pos = 0.0  # samples generated, fractional
        self._t = 0.0

    def record(self, name, *args, **kwargs):
        with self.lock:
            self.calls.append((name, args, kwargs))

    def names(self):
        return [c[0] for c in self.calls]

    def advance(self):
        """The hardware: generate at ``rate`` since the last look, never past what was written."""
        t = time.perf_counter()
        if self.running:
            self._pos = min(float(len(self._pending)), self._pos + (t - self._t) * self.rate)
            self._generated = int(self._pos)
        self._t = t

    def end_run(self):
        self.advance()
        gen = list(self._pending[: self._generated])
        self.runs.append(np.array(gen))
        last = gen[-1] if gen else 0.0
        self.held.append(0.0 if self.idle is AOIdleOutputBehavior.ZERO_VOLTS else last)
        self.running = False
        self._pending, self._generated, self._pos = [], 0, 0.0


class FakeAOChannel:
    def __init__(self, dev):
        self._dev = dev

    @property
    def ao_idle_output_behavior(self):
        return self._dev.idle

    @ao_idle_output_behavior.setter
    def ao_idle_output_behavior(self, val):
        self._dev.record("AOChannel.ao_idle_output_behavior=", val)
        if not self._dev.idle_zero:
            raise DaqError("Specified property is not supported by the device or is not applicable to the task.",
                           -200452)
        self._dev.idle = val


class FakeAOChannelCollection:
    def __init__(self, dev):
        self._dev = dev

    @recorded("AOChannelCollection.add_ao_voltage_chan")
    def add_ao_voltage_chan(self, physical_channel, name_to_assign_to_channel="", min_val=-10.0, max_val=10.0,
                            units=None, custom_scale_name=""):
        if physical_channel.split("/")[0] not in self._dev.devices:
            raise DaqError("Device identifier is invalid.", NO_DEVICE)
        self._dev.range = (min_val, max_val)
        return FakeAOChannel(self._dev)


class FakeTiming:
    def __init__(self, dev):
        self._dev = dev

    @recorded("Timing.cfg_samp_clk_timing")
    def cfg_samp_clk_timing(self, rate, source="", active_edge=None, sample_mode=AcquisitionType.FINITE,
                            samps_per_chan=1000):
        self._dev.rate = float(rate)
        self._dev.buf = int(samps_per_chan)


class FakeOutStream:
    def __init__(self, dev):
        self._dev = dev
        self._regen = RegenerationMode.ALLOW_REGENERATION

    @property
    def regen_mode(self):
        return self._regen

    @regen_mode.setter
    def regen_mode(self, val):
        self._dev.record("OutStream.regen_mode=", val)
        self._regen = val

    @property
    def output_buf_size(self):
        return self._dev.buf

    @output_buf_size.setter
    def output_buf_size(self, val):
        self._dev.record("OutStream.output_buf_size=", val)
        self._dev.buf = int(val)

    @property
    def total_samp_per_chan_generated(self):
        dev = self._dev
        dev.record("OutStream.total_samp_per_chan_generated")
        with dev.lock:
            dev.advance()
            return dev._generated


class FakeTask:
    def __init__(self, *args, **kwargs):
        dev = _DEVICE[0]
        dev.record("Task.__init__", *args, **kwargs)
        if not dev.driver:
            raise DaqNotFoundError("Could not find an installation of NI-DAQmx. Please ensure that NI-DAQmx is "
                                   "installed on this machine or contact National Instruments for support.")
        self._dev = dev
        self.ao_channels = FakeAOChannelCollection(dev)
        self.timing = FakeTiming(dev)
        self.out_stream = FakeOutStream(dev)
        dev.task_alive = True

    @recorded("Task.start")
    def start(self):
        dev = self._dev
        if dev.rate > dev.max_rate:
            raise DaqError("Requested value is not a supported value for this property.", INVALID_VALUE)
        with dev.lock:
            assert dev._pending, "a non-regenerating task must be written before it starts"
            dev.running, dev._t = True, time.perf_counter()

    @recorded("Task.stop")
    def stop(self):
        dev = self._dev
        with dev.lock:
            if dev.running:
                dev.end_run()

    @recorded("Task.control")
    def control(self, action):
        if action is TaskMode.TASK_ABORT:
            self._dev.aborted.set()

    @recorded("Task.close")
    def close(self):
        dev = self._dev
        with dev.lock:
            if dev.running:
                dev.end_run()
            dev.task_alive = False


class FakeWriter:
    def __init__(self, *args, **kwargs):
        self._dev = _DEVICE[0]
        self._dev.record("AnalogSingleChannelWriter.__init__", *args, **kwargs)

    @recorded("AnalogSingleChannelWriter.write_many_sample")
    def write_many_sample(self, data, timeout=10.0):
        dev = self._dev
        assert isinstance(data, np.ndarray) and data.dtype == np.float64 and data.ndim == 1 and data.flags.c_contiguous
        lo, hi = dev.range
        assert np.all(data >= lo) and np.all(data <= hi), "a value beyond the channel's range"
        dev.n_writes += 1
        k = dev.n_writes
        dev.writes.append(data.copy())
        if k in dev.underrun_at or (dev.underrun_if is not None and not dev.underrun_writes and dev.underrun_if(k, data)):
            dev.underrun_writes.append(k)
            with dev.lock:  # the buffer ran empty: the device stopped at the last sample written before
                dev._pos = float(len(dev._pending))
                dev.end_run()
            raise DaqWriteError("The generation has stopped to prevent the regeneration of old samples.",
                                REGEN_STOPPED, 0)
        if k == dev.hang_at:
            dev.aborted.wait()
            raise DaqWriteError("The operation was aborted.", ABORTED, 0)
        end = time.perf_counter() + timeout
        while True:
            with dev.lock:
                dev.advance()
                if len(dev._pending) - dev._generated + data.shape[0] <= dev.buf:
                    dev._pending.extend(data.tolist())
                    return data.shape[0]
            if time.perf_counter() > end:
                raise DaqWriteError("Some or all of the samples to write could not be written to the buffer yet.",
                                    NOT_YET_WRITTEN, 0)
            time.sleep(0.0002)


_DEVICE: list = [None]


def install(monkeypatch, device: FakeDevice) -> FakeDevice:
    """Make ``import nidaqmx`` (and the submodules the backend uses) give this stand-in."""
    _DEVICE[0] = device
    root = types.ModuleType("nidaqmx")
    root.Task = FakeTask
    constants = types.ModuleType("nidaqmx.constants")
    for e in ENUMS:
        setattr(constants, e.__name__, e)
    errors = types.ModuleType("nidaqmx.errors")
    for e in ERRORS:
        setattr(errors, e.__name__, e)
    writers = types.ModuleType("nidaqmx.stream_writers")
    writers.AnalogSingleChannelWriter = FakeWriter
    root.constants, root.errors, root.stream_writers = constants, errors, writers
    for name, mod in [("nidaqmx", root), ("nidaqmx.constants", constants), ("nidaqmx.errors", errors),
                      ("nidaqmx.stream_writers", writers)]:
        monkeypatch.setitem(sys.modules, name, mod)
    return device
