"""The real-time block engine.

A backend (sound card callback, simulated display thread, file writer, OSC sender) owns the
clock and calls :meth:`LiveEngine.render` once per block. Touch sources (web page, OSC,
replayed trajectory) call :meth:`LiveEngine.push_touch` from their own threads; control
code calls :meth:`LiveEngine.send`. Everything between the two sides goes through the
bounded, non-blocking :class:`~surfhap.live.queues.TouchRing` and
:class:`~surfhap.live.queues.CommandQueue`.

Real-time contract of :meth:`LiveEngine.render` (it runs inside PortAudio's callback):

* it MAY: pop pending commands and touch samples (non-blocking, bounded by the preallocated
  buffers), run the kinematics stage and the processors (texture chain with its safety
  stage and watchdog, optional simulated display), write into preallocated rings (drive
  FIFO, trace, latency, timing), increment integer counters, set plain attributes;
* it MUST NOT: take a lock that a producer can hold, wait, sleep, log, print, open files or
  sockets, build Python containers that grow, import modules, or raise (a failure of a
  processor outputs silence for the block and is counted in ``counters['errors']``).
  Buffers are allocated in ``__init__``/``reset``; the touch hold and the chain's stages are
  compiled calls per chunk (a chain block allocates only its outputs).

The last processor before the backend is the engine's :class:`~surfhap.render.safety.OutputSafety`
pass (``self.guard``): gain and stop ramp are applied inside it, and it holds ``v_max``,
the rise limit (remembering the last emitted magnitude across blocks, lifts, gain changes
and renderer switches) and the watchdog on each sample's emission time. ``fail(reason)``
halts the engine at 0 V (a backend that raised or stalled).

Touch samples are stamped at arrival on the engine's own clock (:func:`surfhap.runtime.clock.now`
or the constructor's ``clock``) in :meth:`LiveEngine.push_touch`; a caller's ``t_arrival`` may
only make a sample older (:func:`surfhap.runtime.clock.arrival_stamp`). Each sample is in
force from the model sample at its stamp on (:class:`surfhap.render.hold.TouchHold`), and the
renderer's watchdog (touch older than 50 ms -> ramp to zero within 5 ms) sees that stamp, never
refreshed: data that waited during a stall stays stale. ``now`` given to
:meth:`LiveEngine.render` is the backend's emission time of the block on the same clock.

Latency (``latency_stats``): for every touch sample applied, the time from its arrival to
the emission of the first drive sample computed from it (the block's emission time ``now``
plus the sample's offset in the block). The sound backend passes PortAudio's DAC time, so
there it includes the output latency; the amplifier adds its own.
"""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np

from surfhap.errors import ConfigError
from surfhap.runtime.clock import arrival_stamp, now as clock_now
from surfhap.live.engine_config import EngineConfig
from surfhap.live.fifo_kernels import fifo_read, record_chunk
from surfhap.render.kinematics import TouchPredictor
from surfhap.live.queues import CommandQueue, TouchRing, ring_rows_since, ring_stats
from surfhap.render.hold import NO_LIFT, TouchHold
from surfhap.render.safety import OutputSafety
from surfhap.runtime.commands import Command, SetGain, Stop, SwapRenderer
from surfhap.runtime.protocols import Renderer

__all__ = ["LiveEngine", "TRACE_FIELDS"]

_NO_FRICTION = np.zeros(0)  # a block without a simulated display: its trace row's friction is NaN
# one row per processed chunk
TRACE_FIELDS = ("t", "x", "y", "speed", "load", "v_peak", "target", "friction")


class LiveEngine:
    """Real-time engine around one :class:`~surfhap.render.block.Renderer` (a
    :class:`~surfhap.render.chain.TextureChain` or a
    :class:`~surfhap.render.shape_chain.ShapeChain`).

    Each chunk calls ``renderer.process(speed, load, touch_time, x, y)`` and reads the
    :class:`~surfhap.render.block.RenderBlock` it returns: ``drive`` (volts at the drive
    rate, already through the renderer's safety stage), ``load_drive`` and ``target``.
    """

    def __init__(self, renderer: Renderer, config: EngineConfig | None = None, display=None, clock=None):
        self.config = cfg = config or EngineConfig()
        self.renderer = renderer
        self.drive_rate = int(renderer.drive_rate)
        self.control_rate = int(renderer.control_rate)
        self.block_frames = max(1, int(round(cfg.block_seconds * self.drive_rate)))
        self.block_period = self.block_frames / self.drive_rate
        self.v_max = float(renderer.safety.limits.v_max)
        self.drive_unit = "V"  # the trace's drive column, full scale ``drive_full_scale``
        self.frame_extra = None  # no extra trace part (the force-feedback view has one)
        self.display = display
        self.touches = TouchRing(cfg.touch_capacity)
        self.commands = CommandQueue(64)
        self._pending = self.commands.pending
        self.predictor = TouchPredictor(cfg.touch_latency, cfg.smoothing, cfg.k_pred, cfg.speed_cutoff)
        self.counters: dict = {}
        self.hold = TouchHold(self.touches, self.predictor, cfg.takeover, self.counters)
        mb = int(cfg.max_block_frames)
        self._max_frames = mb
        self._max_model = int(math.ceil(mb * self.control_rate / self.drive_rate)) + 2
        self._inputs = np.zeros((5, self._max_model))  # speed, load, touch time, x, y of a chunk
        self._views: dict = {}  # n -> (self._inputs[:, :n], its rows): made once per chunk length
        self._fifo_cap = 1 << (4 * mb + 8 * self.drive_rate // self.control_rate + 63).bit_length()  # a power of two
        self._fifo = np.zeros(self._fifo_cap)
        self._fifo_mask = self._fifo_cap - 1
        self.out = np.zeros(mb)  # volts of the last block
        self.trace = np.zeros((cfg.trace_capacity, len(TRACE_FIELDS)))
        self.latencies = np.zeros(cfg.latency_capacity)
        self.block_times = np.zeros(cfg.latency_capacity)  # seconds spent in render()
        self.guard = OutputSafety(self.drive_rate, renderer.safety.limits, cfg.stop_ramp)
        self.clock = clock_now if clock is None else clock  # the engine clock (s); tests may simulate it
        self.reset()

    # ------------------------------------------------------------------ control side
    def reset(self) -> None:
        """Back to silence with no finger; counters zeroed. Not for use while a backend runs."""
        self.renderer.reset()
        if self.display is not None:
            self.display.reset()
        self.hold.reset()
        self.touches.clear()
        self._fifo_r = 0
        self._fifo_w = 0
        self._n_model = 0
        self._gain = 1.0
        self.guard.set_limits(self.renderer.safety.limits)
        self.guard.reset()
        self.stopping = False
        self.stopped = False
        self.halted = False
        self.failure: str | None = None
        self.trace_count = 0
        self.latency_count = 0
        self.block_time_count = 0
        self.counters.clear()
        self.counters.update({
            "blocks": 0, "frames": 0, "touches": 0, "touches_ignored": 0, "underruns": 0,
            "overruns": 0, "errors": 0, "commands": 0, "backend_failures": 0, "stale_stamps": 0,
        })

    def warm_up(self, blocks: int = 20) -> None:
        """Run a few blocks with a short stroke (loads compiled kernels, touches every
        buffer), then reset.

        Call before a backend starts, so the first real-time blocks are not slow."""
        t = self.clock()
        for i in range(blocks):  # a short stroke, so the touch paths are compiled too
            t += self.block_period
            if i % 4 == 0 and i < blocks - 4:
                self.push_touch(-1, 0.05 + 0.0005 * i, 0.05, 0.5, t_event=t)
            elif i == blocks - 4:
                self.push_touch(-1, 0.0, 0.0, 0.0)
            self.render(self.block_frames, t)
        self.reset()

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan,
                   t_arrival: float | None = None) -> bool:
        """Hand one validated touch sample to the engine (any thread; never blocks long).

        x, y in m; load in N (0 = lifted); ``t_event`` the source's own time stamp in s
        (orders the samples for the speed estimate only). The engine stamps the arrival on
        its own clock; ``t_arrival`` (engine clock, s) may only make the sample older: a
        future or non-finite stamp makes it stale (see the module docstring).
        Returns False when the ring is full (the sample is dropped and counted).
        """
        ta = arrival_stamp(t_arrival, self.clock())
        return self.touches.push(source, t_event, ta, x, y, load)

    def send(self, command: Command) -> bool:
        """Queue a typed command (:mod:`surfhap.runtime.commands`): :class:`Stop`,
        :class:`SetGain` (applied inside the output safety pass, so a gain step is
        rise-limited) or :class:`SwapRenderer` (same drive rate). Anything else raises."""
        if not isinstance(command, (Stop, SetGain, SwapRenderer)):
            raise TypeError(f"not an engine command: {command!r} (see surfhap.runtime.commands)")
        if isinstance(command, SwapRenderer):
            r = command.renderer
            if int(r.drive_rate) != self.drive_rate:
                raise ConfigError("a new renderer must keep the drive rate", field="drive_rate")
            if math.ceil(self._max_frames * r.control_rate / self.drive_rate) + 2 > self._max_model:
                raise ConfigError("a new renderer's control rate is too high for this engine", field="control_rate")
        return self.commands.put(command)

    def request_stop(self) -> None:
        """Ramp the output to zero over ``stop_ramp`` and then output silence."""
        self.send(Stop())

    def fail(self, reason: str) -> None:
        """Mark the output as failed (a backend raised or stalled; any thread): every later
        block is 0 V, ``failure`` holds the first reason and ``counters['backend_failures']``
        counts the reports. The engine stays halted until :meth:`reset`."""
        if self.failure is None:
            self.failure = str(reason)[:300]
        self.halted = True
        self.counters["backend_failures"] += 1

    def output_zeroed(self) -> None:
        """The backend put 0 V out in place of rendered samples (a DAQ restarted after an
        underrun): the output pass's rise limit starts again from 0 V. Call from the thread
        that calls :meth:`render`."""
        self.guard.silence()

    # ------------------------------------------------------------------ real-time side
    def render(self, frames: int, now: float | None = None) -> np.ndarray:
        """Produce the next ``frames`` drive samples (volts); returns a view of ``self.out``.

        Runs inside the audio callback; see the module docstring for what it may do.
        ``now`` is the engine-clock time at which the block starts to be emitted.
        """
        t_start = self.clock()
        if now is None:
            now = t_start
        if frames > self._max_frames:
            frames = self._max_frames
            self.counters["overruns"] += 1
        out = src = self.out[:frames]
        try:
            if self._pending:
                self._commands()
            self.hold.take(now, self._n_model / self.control_rate)
            self._produce(frames, now)
            i = self._fifo_r & self._fifo_mask
            if i + frames <= self._fifo_cap:  # the block's samples lie in one piece of the FIFO
                src = self._fifo[i:i + frames]
            else:
                fifo_read(self._fifo, self._fifo_mask, self._fifo_r, out)
            self._fifo_r += frames
        except Exception:  # noqa: BLE001 - the callback must never raise
            self.counters["errors"] += 1
            out[:] = 0.0
            src = out
        # the last processor before the backend (from the FIFO into out): gain, stop ramp, v_max,
        # rise limit and watchdog on the emitted samples, remembering the last emitted magnitude
        try:
            self.guard.process(src, out, now - self.hold.last_arrival, self._gain, self.halted)
            if self.stopping and self.guard.ramped_down:
                self.stopped = True
        except Exception:  # noqa: BLE001
            self.counters["errors"] += 1
            out[:] = 0.0
            self.guard.silence()
        c = self.counters
        c["blocks"] += 1
        c["frames"] += frames
        spent = self.clock() - t_start
        self.block_times[self.block_time_count & (self.block_times.shape[0] - 1)] = spent
        self.block_time_count += 1
        if spent > frames / self.drive_rate:
            c["overruns"] += 1
        return out

    def _commands(self) -> None:
        for _ in range(8):
            cmd = self.commands.get_nowait()
            if cmd is None:
                return
            self.counters["commands"] += 1
            if isinstance(cmd, Stop):
                if not self.stopping:
                    self.stopping = True
                    self.guard.start_ramp()
            elif isinstance(cmd, SwapRenderer):
                # the new renderer's sample clock starts at 0 where the old one stood: it starts
                # from its reset state, reset here, in the thread that runs it (a reset from the
                # sender's thread could land inside a block the engine is rendering with it)
                self.hold.anchor += self._n_model / self.control_rate
                cmd.renderer.reset()
                self.renderer = cmd.renderer
                self._n_model = 0
                self.v_max = float(self.renderer.safety.limits.v_max)
                self.control_rate = int(self.renderer.control_rate)
                self.guard.set_limits(self.renderer.safety.limits)
            else:
                self._gain = float(cmd.gain)

    def _produce(self, frames: int, now: float) -> None:
        while self._fifo_w - self._fifo_r < frames:
            need = frames - (self._fifo_w - self._fifo_r)
            n = int(math.ceil(need * self.control_rate / self.drive_rate))
            if n < 1:
                n = 1
            if n > self._max_model:
                n = self._max_model
            k0 = self._n_model
            views = self._views.get(n)
            if views is None:
                views = self._views[n] = (self._inputs[:, :n], tuple(self._inputs[:, :n]))
            inputs, rows = views
            h = self.hold
            k_lift = h.fill(k0, self.control_rate, inputs)
            if k_lift != NO_LIFT:
                # lifted late (the chain is past the lift's stamp): the drive queued since the
                # lift's model sample is silenced at once; removing voltage is always safe
                late = int(math.ceil((k0 - k_lift) * self.drive_rate / self.control_rate))
                for j in range(max(self._fifo_r, self._fifo_w - late), self._fifo_w):
                    self._fifo[j & self._fifo_mask] = 0.0
            drive, _, target, _, friction = self.renderer.process(*rows, display=self.display)
            m = drive.shape[0]
            # the touches put in force in this chunk are first heard at their position in it
            applied = h.n_applied if m else 0
            record_chunk(self._fifo, self._fifo_mask, self._fifo_w, drive, self.trace, self.trace_count, k0 / self.control_rate,
                         inputs, target, _NO_FRICTION if friction is None else friction, self.latencies, self.latency_count,
                         h.latencies, applied, now, self._fifo_w - self._fifo_r, self.drive_rate)
            if applied:
                self.latency_count += applied
                h.n_applied = 0
            self._fifo_w += m
            self._n_model += n
            self.trace_count += 1

    # ------------------------------------------------------------------ monitoring side
    def trace_since(self, index: int, limit: int | None = None) -> tuple[np.ndarray, int]:
        """Rows of the trace written since ``index`` (oldest first) and the new index.

        Safe from any thread: copies (at most the ring's length, and at most ``limit`` of
        the newest rows)."""
        return ring_rows_since(self.trace, self.trace_count, index, limit)

    def latency_stats(self) -> dict:
        """Arrival -> first affected drive sample, s (p50, p99, max, last) over the ring."""
        return ring_stats(self.latencies, self.latency_count)

    def block_time_stats(self) -> dict:
        """Seconds spent in render() per block (p50, p99, max, last) over the ring."""
        return ring_stats(self.block_times, self.block_time_count)

    def safety_counters(self) -> dict:
        return asdict(self.renderer.safety.counters)

    def output_safety_counters(self) -> dict:
        return asdict(self.guard.counters)

    @property
    def drive_full_scale(self) -> float:
        """V: the full scale of the trace's drive column (``v_max``)."""
        return self.v_max

    def status(self) -> dict:
        """Counters, latency and timing as plain JSON-able values (monitoring threads).

        ``failure`` is None, or why the output failed (backend raised or stalled)."""
        return {
            "counters": dict(self.counters, touches_dropped=self.touches.dropped, commands_dropped=self.commands.dropped),
            "safety": self.safety_counters(),
            "output_safety": self.output_safety_counters(),
            "failure": self.failure,
            "latency": self.latency_stats(),
            "block_time": self.block_time_stats(),
            "block_period": self.block_period,
            "drive_rate": self.drive_rate,
            "control_rate": self.control_rate,
            "stopped": self.stopped,
        }
