"""``daq``: one NI-DAQmx analog output channel (``Dev1/ao0``) through NI's ``nidaqmx`` package
(MIT; NI's driver, NI-DAQmx, must be installed too). Never run on hardware: the tests check the
calls against a recorded stand-in and their signatures against the installed package.

The channel generates continuously on the device's sample clock at the engine's drive rate with
regeneration off (a sample is never generated twice: a writer that falls behind stops the
generation instead of repeating old drive). It writes ``volts / amp_gain`` (``amp_gain``: the
amplifier's V per V at its input); the channel's range is ``±v_max / amp_gain``, within the
±10 V of NI's AO channels. The host buffer is :attr:`PacedBackend.buffer` (5 ms) in whole
blocks, at least two, filled with 0 V before the start.

The blocks go through the one block loop in :class:`PacedBackend`'s thread on
:class:`DaqClock`: the device paces them (a write blocks until the buffer has room), and each
block is stamped with the moment its first sample leaves the DAC (now plus the samples written
and not yet generated, device FIFO included), so the engine's watchdog holds at the DAC.

NI reports an underrun as an error of the next write (:data:`UNDERRUN_CODES`): the generation
has stopped. It is counted (``engine.counters['underruns']``, :attr:`DaqBackend.underruns`), the
block dropped, the task restarted on a buffer of 0 V and the engine's output pass told so (its
rise limit starts again from 0 V). The channel idles at 0 V where the device supports it
(``ao_idle_output_behavior``), else it holds its last sample when the generation stops (logged).
A stop ramps to zero and waits (bounded) until the device has generated the ramp; any other
error, or no block for ``stall_timeout`` s (the task is aborted), halts the engine (exit 3).
"""

from __future__ import annotations

import logging
import math
import threading

import numpy as np

from surfhap.errors import ConfigError
from surfhap.live.backends.base import PacedBackend
from surfhap.runtime.clock import WallClock, now

__all__ = ["DaqBackend", "DaqClock", "UNDERRUN_CODES", "AO_RANGE"]

log = logging.getLogger("surfhap.live")

# nidaqmx.error_codes.DAQmxErrors: GEN_STOPPED_TO_PREVENT_REGEN_OF_OLD_SAMPLES (the host buffer ran
# empty with regeneration off), OUTPUT_FIFO_UNDERFLOW_2, OUTPUT_FIFO_UNDERFLOW, DAC_UNDERFLOW
UNDERRUN_CODES = frozenset({-200290, -200621, -200016, -200018})
AO_RANGE = 10.0  # V: the range of NI's AO channels (add_ao_voltage_chan's default min_val/max_val)


def _nidaqmx():
    try:
        import nidaqmx
        from nidaqmx import constants, errors, stream_writers
    except ImportError:
        raise ConfigError("nidaqmx is not installed; pip install 'surfhap[daq]' (and NI-DAQmx, NI's driver)",
                          source="--output") from None
    return nidaqmx, constants, errors, stream_writers


def _first_line(exc) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


class DaqClock(WallClock):
    """Wall time, the blocks paced by the DAQ (a write blocks while its buffer is full); a block
    is stamped with the moment its first sample leaves the DAC (as :class:`AudioClock`)."""

    def __init__(self, backend: "DaqBackend"):
        super().__init__()
        self.backend = backend

    def wait_until(self, deadline: float) -> float:
        b = self.backend
        return now() + (b.written - b.generated) / b.rate


class DaqBackend(PacedBackend):
    name = "daq"
    paced_by_device = True
    buffer = math.inf  # the loop never re-anchors: the device paces and reports its underruns

    def __init__(self, channel: str, amp_gain: float = 250.0):
        super().__init__()
        if not (np.isfinite(amp_gain) and amp_gain > 0):
            raise ConfigError("must be > 0 V per V at the amplifier input", source="--amp-gain")
        self.channel, self.amp_gain = channel, float(amp_gain)
        self.clock = DaqClock(self)
        self.underruns = self.written = self.generated = self.rate = self.buffer_frames = 0
        self.idle_zero = False
        self._task = None
        self._drained = threading.Event()
        self._mark: int | None = None

    def open(self, engine) -> None:
        super().open(engine)
        nidaqmx, const, self._errors, writers = _nidaqmx()
        self.rate = rate = int(engine.drive_rate)
        self._peak = peak = engine.v_max / self.amp_gain
        if not peak <= AO_RANGE:
            raise ConfigError(f"v_max {engine.v_max:g} V needs {peak:.3g} V at the DAQ output, beyond its "
                              f"±{AO_RANGE:g} V: give your amplifier's gain (V/V)", source="--amp-gain")
        self.buffer_frames = buf = engine.block_frames * max(2, math.ceil(PacedBackend.buffer / engine.block_period))
        self._units = np.zeros(engine.config.max_block_frames)
        self._zeros = np.zeros(buf)
        try:
            task = nidaqmx.Task()
        except self._errors.Error as exc:  # DaqNotFoundError: no driver
            raise ConfigError(f"no NI-DAQmx driver ({_first_line(exc)})", source="--output") from None
        self._abort_mode = const.TaskMode.TASK_ABORT
        self._drained.clear()
        self._mark = None
        try:
            chan = task.ao_channels.add_ao_voltage_chan(self.channel, min_val=-peak, max_val=peak)
            try:
                chan.ao_idle_output_behavior = const.AOIdleOutputBehavior.ZERO_VOLTS
                self.idle_zero = True
            except self._errors.DaqError as exc:
                log.warning("%s cannot idle at 0 V (%s): it holds its last sample when the generation stops",
                            self.channel, _first_line(exc))
            task.timing.cfg_samp_clk_timing(rate, sample_mode=const.AcquisitionType.CONTINUOUS, samps_per_chan=buf)
            task.out_stream.regen_mode = const.RegenerationMode.DONT_ALLOW_REGENERATION
            task.out_stream.output_buf_size = buf
            self._writer = writers.AnalogSingleChannelWriter(task.out_stream, auto_start=False)
            self._task = task
            self._start_task()  # the device checks the rate and the buffer here
        except self._errors.Error as exc:
            self._task = None
            task.close()
            raise ConfigError(f"cannot open DAQ channel {self.channel} at {rate} Hz ({_first_line(exc)})",
                              source="--output") from None

    def _start_task(self) -> None:
        """Fill the buffer with 0 V and start the generation (the sample counts restart at 0)."""
        self._writer.write_many_sample(self._zeros, timeout=self.stall_timeout)
        self.written, self.generated = self._zeros.shape[0], 0
        self._task.start()

    def emit(self, volts) -> None:
        eng = self.engine
        u = self._units[: volts.shape[0]]
        np.multiply(volts, 1.0 / self.amp_gain, out=u)
        np.clip(u, -self._peak, self._peak, out=u)
        try:
            self._writer.write_many_sample(u, timeout=self.stall_timeout)
            self.written += u.shape[0]
            self.generated = self._task.out_stream.total_samp_per_chan_generated
        except self._errors.DaqError as exc:
            if exc.error_code not in UNDERRUN_CODES:
                raise
            self.underruns += 1
            eng.counters["underruns"] += 1
            if self.underruns == 1:
                log.warning("DAQ output underrun (%s): restarted on 0 V; later ones are counted", exc.error_code)
            eng.output_zeroed()
            self._task.stop()
            self._start_task()
        if self._mark is None and (eng.stopped or eng.halted):
            self._mark = self.written  # silent from here: done once the device has generated it
        elif self._mark is not None and self.generated >= self._mark:
            self._drained.set()

    def drained(self, timeout: float) -> None:
        self._drained.wait(timeout)  # the ramp has left the DAC

    def abort(self) -> None:
        if self._task is not None:
            self._task.control(self._abort_mode)

    def close(self) -> None:
        task, self._task = self._task, None
        if task is None:
            return
        try:
            task.stop()
        except self._errors.DaqError as exc:  # e.g. the underrun of a halted output
            log.warning("DAQ output stop: %s", _first_line(exc))
        finally:
            task.close()

    def info(self) -> dict:
        return {"name": self.name, "channel": self.channel, "amp_gain": self.amp_gain, "underruns": self.underruns,
                "buffer_frames": self.buffer_frames, "idle_zero": self.idle_zero,
                "output_latency": (self.written - self.generated) / self.rate if self.rate else None}
