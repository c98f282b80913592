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
  The engine's own buffers are allocated in ``__init__``; the texture chain's numpy kernels
  make a few short temporaries per block (bounded size; no per-sample allocation).

The last processor before the backend is the engine's :class:`~surfhap.render.safety.OutputSafety`
pass (``self.guard``): gain and stop ramp are applied inside it, and it holds ``v_max``,
the rise limit (remembering the last emitted magnitude across blocks, lifts, gain changes
and renderer switches) and the watchdog on each sample's emission time. ``fail(reason)``
halts the engine at 0 V (a backend that raised or stalled).

Touch samples are time-stamped at arrival by the engine itself, on its own clock
(:func:`surfhap.live.clock.now`, or the ``clock`` given to the constructor), in
:meth:`LiveEngine.push_touch`. A caller's stamp (``t_arrival``, e.g. the web process's
arrival time) may only make a sample older, never extend its life
(:func:`surfhap.live.clock.arrival_stamp`): a stamp from the future, NaN or +-inf, and a
stamp earlier than the previous one of the same source (non-monotonic), makes the sample
stale, counted in ``counters['stale_stamps']``; a stale sample never refreshes the
watchdog (its position is not used; a stale lift still lifts). At each block the freshest
sample is mapped onto the chain's sample clock as ``chain_time - (now - t_arrival)``, so
the watchdog of the safety stage (touch older than 50 ms -> ramp to zero within 5 ms) sees
how old the finger data really is. A stamp is never refreshed: data that waited during a
stall stays stale. ``now`` given to :meth:`LiveEngine.render` is the backend's emission
time of the block on the same clock (the backend owns the clock; it is not caller input).

Latency (``latency_stats``): for every touch sample applied, the time from its arrival to
the emission of the first drive sample computed from it (the block's emission time ``now``
plus the sample's offset in the block). The sound backend passes PortAudio's DAC time, so
there it includes the output latency; the amplifier adds its own.
"""

from __future__ import annotations

import math

import numpy as np

from surfhap.errors import ConfigError
from surfhap.live.clock import STALE, arrival_stamp, now as clock_now
from surfhap.live.engine_config import EngineConfig
from surfhap.live.fifo_kernels import fifo_read, fifo_write_peak, mean_or_nan, write_trace_row
from surfhap.live.prediction import TouchPredictor
from surfhap.live.queues import CommandQueue, TouchRing, ring_rows_since, ring_stats
from surfhap.render.block import Renderer
from surfhap.render.safety import OutputSafety

__all__ = ["LiveEngine", "TRACE_FIELDS"]

# one row per processed chunk
TRACE_FIELDS = ("t", "x", "y", "speed", "load", "v_peak", "target", "friction")
_NO_TOUCH_TIME = -1.0e6  # "touched long ago": the watchdog holds the output at zero


def _pow2_at_least(n: int) -> int:
    return 1 << max(1, int(n - 1).bit_length())


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
        self.model_rate = int(renderer.model_rate)
        self.block_frames = max(1, int(round(cfg.block_seconds * self.drive_rate)))
        self.block_period = self.block_frames / self.drive_rate
        self.v_max = float(renderer.safety.limits.v_max)
        self.display = display
        self.touches = TouchRing(cfg.touch_capacity)
        self.commands = CommandQueue(64)
        self.predictor = TouchPredictor(cfg.touch_latency, cfg.smoothing, cfg.k_pred, cfg.speed_cutoff)
        mb = int(cfg.max_block_frames)
        self._max_frames = mb
        self._max_model = int(math.ceil(mb * self.model_rate / self.drive_rate)) + 2
        self._speed = np.zeros(self._max_model)
        self._load = np.zeros(self._max_model)
        self._ttime = np.zeros(self._max_model)
        self._xs = np.zeros(self._max_model)
        self._ys = np.zeros(self._max_model)
        self._fifo_cap = _pow2_at_least(4 * mb + 8 * self.drive_rate // self.model_rate + 64)
        self._fifo = np.zeros(self._fifo_cap)
        self._fifo_mask = self._fifo_cap - 1
        self.out = np.zeros(mb)  # volts of the last block
        self._touch_buf = np.zeros((256, 6))
        self._pending_arrivals = np.zeros(256)
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
        self.predictor.reset()
        self.touches.clear()
        self._fifo_r = 0
        self._fifo_w = 0
        self._n_model = 0
        self._n_pending = 0
        self._owner = -1.0
        self._owner_active = False
        self._owner_arrival = -math.inf
        self._last_arrival = -math.inf
        self._last_source_time = math.nan
        self._load_now = 0.0
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
        self.counters = {
            "blocks": 0, "frames": 0, "touches": 0, "touches_ignored": 0, "underruns": 0,
            "overruns": 0, "errors": 0, "commands": 0, "backend_failures": 0, "stale_stamps": 0,
        }

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

    def send(self, *command) -> bool:
        """Queue a command: ``("stop",)``, ``("renderer", new_renderer)`` (same drive rate;
        build it outside the callback), ``("gain", g)`` with g in [0, 1] (anything else is ignored);
        the gain is applied inside the output safety pass, so a gain step is rise-limited."""
        if command and command[0] == "renderer":
            r = command[1]
            if int(r.drive_rate) != self.drive_rate:
                raise ConfigError("a new renderer must keep the drive rate", field="drive_rate")
            if math.ceil(self._max_frames * r.model_rate / self.drive_rate) + 2 > self._max_model:
                raise ConfigError("a new renderer's model rate is too high for this engine", field="model_rate")
        return self.commands.put(tuple(command))

    def request_stop(self) -> None:
        """Ramp the output to zero over ``stop_ramp`` and then output silence."""
        self.send("stop")

    def fail(self, reason: str) -> None:
        """Mark the output as failed (a backend raised or stalled; any thread): every later
        block is 0 V, ``failure`` holds the first reason and ``counters['backend_failures']``
        counts the reports. The engine stays halted until :meth:`reset`."""
        if self.failure is None:
            self.failure = str(reason)[:300]
        self.halted = True
        self.counters["backend_failures"] += 1

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
        out = self.out[:frames]
        try:
            self._commands()
            self._touch(now)
            self._produce(frames, now)
            fifo_read(self._fifo, self._fifo_mask, self._fifo_r, out)
            self._fifo_r += frames
        except Exception:  # noqa: BLE001 - the callback must never raise
            self.counters["errors"] += 1
            out[:] = 0.0
        # the last processor before the backend: gain, stop ramp, v_max, rise limit and
        # watchdog on the emitted samples, remembering the last emitted magnitude
        try:
            self.guard.process(out, out, now - self._last_arrival, self._gain, self.halted)
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
            kind = cmd[0]
            if kind == "stop" and not self.stopping:
                self.stopping = True
                self.guard.start_ramp()
            elif kind == "renderer":
                self.renderer = cmd[1]
                self._n_model = 0  # a new renderer's sample clock starts at 0
                self.v_max = float(self.renderer.safety.limits.v_max)
                self.model_rate = int(self.renderer.model_rate)
                self.guard.set_limits(self.renderer.safety.limits)
            elif kind == "gain":
                g = cmd[1]
                if isinstance(g, (int, float)) and 0.0 <= g <= 1.0:  # NaN fails the test
                    self._gain = float(g)

    def _touch(self, now: float) -> None:
        n = self.touches.pop_into(self._touch_buf)
        applied = self._n_pending
        buf = self._touch_buf
        pred = self.predictor
        for i in range(n):
            src, t_ev, t_arr, x, y, load = buf[i, 0], buf[i, 1], buf[i, 2], buf[i, 3], buf[i, 4], buf[i, 5]
            if not t_arr > STALE or (src == self._owner and t_arr < self._owner_arrival):
                # untrusted (future / non-finite) or non-monotonic stamp: stale, counted
                self.counters["stale_stamps"] += 1
                t_arr = STALE
            if src != self._owner:
                if self._owner_active and t_arr - self._owner_arrival < self.config.takeover:
                    self.counters["touches_ignored"] += 1
                    continue
                self._owner = src
                pred.reset()
                self._last_source_time = math.nan
            self._owner_arrival = t_arr
            self._last_arrival = t_arr
            self.counters["touches"] += 1
            if applied < self._pending_arrivals.shape[0] and t_arr > STALE:
                self._pending_arrivals[applied] = t_arr
                applied += 1
            if not load > 0.0:
                self._owner_active = False
                self._load_now = 0.0
                pred.reset()
                # lifted: drive already queued (a slow model rate queues up to one model
                # period) is silenced at once; removing voltage is always safe
                for j in range(self._fifo_r, self._fifo_w):
                    self._fifo[j & self._fifo_mask] = 0.0
                continue
            if t_arr == STALE:  # data of unknown age: not used (the watchdog holds 0 V)
                continue
            self._owner_active = True
            self._load_now = load
            # the source's time stamps give the intervals when they are sane, else arrival
            ts = t_ev if (t_ev == t_ev and (self._last_source_time != self._last_source_time
                                            or t_ev >= self._last_source_time)) else math.nan
            if ts == ts:
                self._last_source_time = ts
                pred.update(ts, x, y)
            else:
                pred.update(t_arr, x, y)
        self._n_pending = applied

    def _produce(self, frames: int, now: float) -> None:
        while self._fifo_w - self._fifo_r < frames:
            need = frames - (self._fifo_w - self._fifo_r)
            n = int(math.ceil(need * self.model_rate / self.drive_rate))
            if n < 1:
                n = 1
            if n > self._max_model:
                n = self._max_model
            chain_t = self._n_model / self.model_rate
            if self._last_arrival > -math.inf:
                age = now - self._last_arrival
                tt = chain_t - (age if age > 0.0 else 0.0)
            else:
                tt = _NO_TOUCH_TIME
            pred = self.predictor
            sp = self._speed[:n]
            ld = self._load[:n]
            ti = self._ttime[:n]
            sp.fill(pred.speed if self._load_now > 0.0 else 0.0)
            ld.fill(self._load_now)
            ti.fill(tt)
            xs = self._xs[:n]
            ys = self._ys[:n]
            xs.fill(pred.x)
            ys.fill(pred.y)
            blk = self.renderer.process(sp, ld, ti, xs, ys)
            drive = blk.drive
            m = drive.shape[0]
            offset = self._fifo_w - self._fifo_r
            peak = fifo_write_peak(self._fifo, self._fifo_mask, self._fifo_w, drive)
            self._fifo_w += m
            self._n_model += n
            friction = math.nan
            if self.display is not None and m:
                friction = mean_or_nan(self.display.process(drive, blk.load_drive))
            if self._n_pending and m:
                # the touches applied since the last chunk are first heard in this one
                t_emit = now + offset / self.drive_rate
                for j in range(self._n_pending):
                    self.latencies[self.latency_count & (self.latencies.shape[0] - 1)] = t_emit - self._pending_arrivals[j]
                    self.latency_count += 1
                self._n_pending = 0
            write_trace_row(self.trace, self.trace_count, chain_t, pred.x, pred.y, sp[0], self._load_now, peak,
                            blk.target[0], friction)
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
        c = self.renderer.safety.counters
        return {k: getattr(c, k) for k in ("samples", "clamped", "rise_limited", "faults", "lifted", "watchdog")}

    def output_safety_counters(self) -> dict:
        c = self.guard.counters
        return {k: getattr(c, k) for k in ("samples", "clamped", "rise_limited", "faults", "watchdog", "halted")}

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
            "model_rate": self.model_rate,
            "stopped": self.stopped,
        }
