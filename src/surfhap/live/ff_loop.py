"""The force-feedback loop on the one runtime: a 1 kHz haptic tick and a 60 Hz position feedback.

Real-time contract (004 Sec. 4.2: "a haptic thread running at about 1000 Hz" and "an
additional 60 Hz thread ... to send the Falcon position to the tablet"):

* :class:`FFLoop` is the engine *and* the sink of :func:`surfhap.runtime.loop.run`: a tick is a
  block of one frame at the engine's rate. ``render(1, t)`` drains the touch ring (bounded),
  reads the device position, runs :class:`surfhap.ff.engine.FFEngine` (kinematics, effects,
  control law, safety stage last) and returns the safe force; ``emit`` writes it to the device
  backend. Nothing in a tick sleeps, logs, allocates arrays or takes a lock that a producer
  holds for long;
* ``ff run`` (:meth:`FFLoop.start`): a thread runs ``run`` on a
  :class:`~surfhap.runtime.clock.WallClock`, the one pacer (a late tick counts the periods it
  skipped as ``underruns``; the period errors feed :meth:`FFLoop.stats`), asking for
  ``SCHED_FIFO`` (:func:`~surfhap.runtime.clock.enter_realtime`, the mode granted: ``scheduling``);
* ``ff simulate`` (:func:`simulate_ff`): the same loop on a
  :class:`~surfhap.runtime.clock.SimClock` with the simulated device and finger;
* stop (Ctrl-C, SIGTERM, ``request_stop``): the safety stage ramps the lateral force to zero at
  its slew rate and puts the tablet down (weight compensation lowered over its ``land_time``),
  the loop runs until the output is zero (at most ``stop_timeout``, counted in ticks), then
  writes one zero force and ends;
* failure: an exception anywhere in a tick (touch drain, device read / write, an effect) is
  kept in ``error`` and turns into a stop through the safety stage (the command exits 3).

The feedback thread sends, at ``feedback_rate``, the device position and the content offset
(``-X_t``, so the tablet draws the content still in the world) to ``feedback(...)`` (an OSC
sender, :class:`OscFeedback`). Touch samples arrive through :meth:`FFLoop.push_touch`, the
call every touch source uses.
"""

from __future__ import annotations

import gc
import logging
import math
import sys
import threading

import numpy as np

from surfhap.ff.engine import FFEngine
from surfhap.ff.tick_kernel import warm_up
from surfhap.live.ff_devices import FFDevice, SimDeviceBackend
from surfhap.live.queues import TouchRing
from surfhap.runtime.clock import SPIN, STALE, Clock, SimClock, WallClock, arrival_stamp, enter_realtime, now
from surfhap.runtime.loop import run
from surfhap.sim.ff_sim import FFSimResult

__all__ = ["FFLoop", "OscFeedback", "WorldTouchAdapter", "simulate_ff"]

log = logging.getLogger("surfhap.live")


class FFLoop:
    """Run ``engine`` against ``backend`` at the engine's rate (``start()``: in a thread).

    engine        : :class:`surfhap.ff.engine.FFEngine`.
    backend       : device backend (:class:`surfhap.live.ff_devices.FFDevice`).
    feedback      : callable ``(t, px, py, pz, dx, dy, fx, fy, fz)`` at ``feedback_rate`` Hz, or None.
    stop_timeout  : s, longest ramp-down on stop (default: the safety stage's landing and ramp).
    history       : ticks of period error kept for the statistics (the wall clock's ring).
    clock         : the runtime clock (default a :class:`WallClock`); also the time base of the
                    arrival stamps (tests driving :meth:`tick_once` pass a :class:`SimClock`).
    realtime      : ask for real-time scheduling of the haptic thread.
    """

    block_frames = 1  # a tick is a block of one frame

    def __init__(self, engine: FFEngine, backend: FFDevice, *, feedback=None, feedback_rate: float = 60.0,
                 stop_timeout: float | None = None, history: int = 1 << 17, clock: Clock | None = None,
                 realtime: bool = True):
        self.engine = engine
        self.clock = WallClock(SPIN, history) if clock is None else clock
        self.backend = backend
        self.rate = self.drive_rate = engine.rate
        self.period = 1.0 / self.rate
        self.feedback = feedback
        self.feedback_rate = float(feedback_rate)
        # long enough for the safety stage to put the tablet down and ramp to zero
        self.stop_timeout = engine.stop_duration + 0.1 if stop_timeout is None else float(stop_timeout)
        self.realtime = bool(realtime)
        self.scheduling = "not started"
        self._switch: float | None = None
        self.touches = TouchRing(1024)
        self.touches_stale = 0
        self._buf = np.zeros((64, 6))
        self.ticks = 0
        self.counters = {"underruns": 0}  # missed ticks, counted by run()
        self._stop = threading.Event()
        self.done = threading.Event()
        self._thread = None
        self._fb_thread = None
        # px, py, pz, fx, fy, fz, active-effect mask, pressed button of the last tick (tuple store: atomic)
        self._last = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, -1)
        self.feedback_snapshot = self._last  # the tick the feedback thread is reporting (read it from feedback)
        self.error = None
        self._stop_left = None  # ticks left for the stop ramp (None = not stopping)
        self._go = True
        self._t = 0.0

    # ------------------------------------------------------------- producers
    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan,
                   t_arrival: float | None = None) -> bool:
        """Hand one validated touch sample to the loop (any thread). x, y m; load N (0 = lifted).

        The loop stamps the arrival on its clock; a caller's ``t_arrival`` can only make the
        sample older (:func:`surfhap.runtime.clock.arrival_stamp`, the texture engine's law too).
        A future or non-finite ``t_arrival`` is stale: counted in ``touches_stale`` and dropped."""
        ta = arrival_stamp(t_arrival, self.clock.now())
        if ta == STALE:
            self.touches_stale += 1
            return False
        return self.touches.push(source, t_event, ta, x, y, load)

    # ------------------------------------------------------------- control
    def start(self) -> None:
        # the haptic thread competes for the GIL with the touch and feedback threads: a short
        # switch interval (process-wide; restored on stop) bounds how long it waits
        self._switch = sys.getswitchinterval()
        sys.setswitchinterval(min(self._switch, 0.0002))
        # the objects alive now (~10^5) are never scanned again by the cyclic collector: a full
        # collection over them stalls the haptic thread for 50-100 ms (unfrozen on stop)
        gc.freeze()
        warm_up()  # the compiled tick, before the first deadline
        self.engine.reset()
        self._stop_left = None
        self._go = True
        self.backend.start()
        self._thread = threading.Thread(target=self._run, name="surfhap-ff-haptic", daemon=True)
        self._thread.start()
        if self.feedback is not None:
            self._fb_thread = threading.Thread(target=self._run_feedback, name="surfhap-ff-feedback", daemon=True)
            self._fb_thread.start()

    def request_stop(self) -> None:
        """Ramp the force to zero and end the loop (returns at once)."""
        self._stop.set()

    def stop(self, timeout: float | None = None) -> None:
        """Request a stop and wait for the ramp-down and the threads."""
        self.request_stop()
        timeout = self.stop_timeout + 2.0 if timeout is None else timeout
        if self._thread is not None:
            self._thread.join(timeout)
        if self._fb_thread is not None:
            self._fb_thread.join(timeout)
        self.backend.stop()
        if self._switch is not None:
            sys.setswitchinterval(self._switch)
            gc.unfreeze()
            self._switch = None

    # ------------------------------------------------------------- the tick
    def _drain(self) -> None:
        buf = self._buf
        n = self.touches.pop_into(buf)
        eng = self.engine
        be = self.backend
        for i in range(n):
            r = buf[i]
            eng.touch(float(r[2]), float(r[3]), float(r[4]), float(r[5]), t_event=float(r[1]))
            be.press(float(r[5]))

    def _fail(self, exc: BaseException) -> None:
        """Keep the first failure (one log line, no traceback on stderr); the tick goes on
        through the safety stage's stop."""
        if self.error is None:
            self.error = exc
            log.debug("ff haptic loop failed", exc_info=exc)
        self._stop.set()

    def render(self, frames: int = 1, now: float | None = None) -> np.ndarray:
        """One haptic tick at ``now`` (s, the loop's clock): drain the touches, read the device
        (its stamp through :func:`arrival_stamp`), tick the engine (its safety stage runs on every
        tick, also after an exception); returns the safe force (3,) N for :meth:`emit`. Once a
        stop has ramped to zero (or used its ``stop_timeout`` worth of ticks: counted in ticks,
        so a stalled loop still ramps) ``running`` turns False."""
        t = self._t = float(now)
        eng, be = self.engine, self.backend
        self.ticks += 1
        px = py = pz = t_pos = math.nan
        try:
            self._drain()
        except Exception as exc:  # noqa: BLE001 - the device is still read: the stop lands the tablet
            self._fail(exc)
        try:
            px, py, pz, t_pos = be.read(t)
        except Exception as exc:  # noqa: BLE001 - no position: the safety stage ramps to zero
            self._fail(exc)
        # the one arrival law, as for touches: a future or non-finite stamp is STALE
        t_pos = arrival_stamp(t_pos, self.clock.now())
        if self._stop.is_set() and self._stop_left is None:
            eng.stop()
            self._stop_left = math.ceil(self.stop_timeout * self.rate)
        ticks = eng.N[0]
        try:
            f = eng.tick(t, px, py, pz, t_pos)
        except Exception as exc:  # noqa: BLE001 - outside the control law: the safety stage alone
            self._fail(exc)
            eng.stop()
            if eng.N[0] == ticks:  # the tick failed before the safety stage took this tick's position
                try:
                    eng.observe(t, t_pos, px, py, pz)
                except Exception:  # noqa: BLE001 - unusable position: the stop below still ramps
                    pass
            f = eng.limit(0.0, 0.0, 0.0, True)  # this tick's clock advanced once: a ramp, never a jump
        if eng.error is not None:
            self._fail(eng.error)
        self._last = (px, py, pz, float(f[0]), float(f[1]), float(f[2]), int(eng.mask), eng.button)
        if self._stop_left is not None:
            self._stop_left -= 1
            if (f[0] == 0.0 and f[1] == 0.0 and f[2] == 0.0) or self._stop_left <= 0:
                self._go = False
        return f

    def emit(self, force: np.ndarray) -> None:
        """Write the tick's force to the device (a failure turns into a stop)."""
        try:
            self.backend.write(force, self._t)
        except Exception as exc:  # noqa: BLE001
            self._fail(exc)

    def running(self) -> bool:
        return self._go

    def tick_once(self, t: float) -> bool:
        """:meth:`render` and :meth:`emit` at ``t`` (tests drive the loop tick by tick); False
        once the loop has ended."""
        self.emit(self.render(1, t))
        return self._go

    # ------------------------------------------------------------- threads
    def _run(self) -> None:
        self.scheduling = enter_realtime() if self.realtime else "normal"
        try:
            run(None, self, self.clock, self, keep_running=self.running, buffer=0.0)
        except Exception as exc:  # noqa: BLE001 - the safety stage itself failed: last resort below
            self._fail(exc)
        finally:
            try:
                self.backend.write(np.zeros(3), now())
            except Exception:  # noqa: BLE001
                log.debug("ff: could not write the final zero force", exc_info=True)
            self.done.set()

    def _run_feedback(self) -> None:
        wall = WallClock(spin=0.0)
        deadline = now()
        while not self.done.is_set():
            deadline += 1.0 / self.feedback_rate
            self._send_feedback(wall.wait_until(deadline))
        self._send_feedback(now())  # the final state (the force at zero after the stop) reaches the tablet too

    def _send_feedback(self, t: float) -> None:
        snap = self.feedback_snapshot = self._last
        px, py, pz, fx, fy, fz = snap[:6]
        try:
            self.feedback(t, px, py, pz, -px, -py, fx, fy, fz)
        except Exception:  # noqa: BLE001 - feedback is best effort
            log.debug("ff feedback failed", exc_info=True)

    # ------------------------------------------------------------- results
    def stats(self) -> dict:
        """Period-error distribution (ms), missed ticks, engine and safety counters (JSON-ready)."""
        e = (self.clock.lateness() if isinstance(self.clock, WallClock) else np.zeros(0)) * 1e3
        pct = (lambda q: float(np.percentile(e, q)) if e.size else 0.0)
        c = self.engine.counters
        return dict(
            ticks=self.ticks, missed=self.counters["underruns"], rate_hz=self.rate,
            period_error_ms={"p50": pct(50), "p99": pct(99), "p999": pct(99.9), "max": pct(100)},
            touches_received=self.touches._write, touches_dropped=self.touches.dropped,
            touches_stale=self.touches_stale + self.engine.touch_stale, touches_rejected=self.engine.touch_rejected,
            safety={k: v for k, v in c._asdict().items() if k != "ticks"},
            device=self.backend.info(), scheduling=self.scheduling,
            error=None if self.error is None else repr(self.error),
        )


def simulate_ff(engine, finger, device, settle: float = 0.3, tail: float = 0.2,
                name: str = "ff simulation") -> FFSimResult:
    """``ff simulate``: the loop on a simulated clock with the simulated ``device``
    (:class:`~surfhap.sim.ff_device.SimDevice`, stepped by the backend on every write, pushed by
    the ``finger``) and the ``finger``'s touch reports (:class:`~surfhap.sim.ff_device.SimFinger`,
    delivered when the simulated tablet sends them), from ``settle`` s before the finger's
    trajectory to ``tail`` s after it (or until a failure's stop has ramped down); the per-tick
    record. The device's gain is the engine's ``device.gain`` (the backend multiplies the safe
    force by it, the device divides its command by it)."""
    if abs(device.rate - engine.rate) > 1e-9:
        raise ValueError("device and engine rates differ")
    t0 = finger.t0 - settle
    n = int(round((finger.t1 + tail - t0) * engine.rate)) + 1
    loop = FFLoop(engine, SimDeviceBackend(device, engine.device.gain, finger=finger), clock=SimClock(t0),
                  realtime=False)
    engine.reset()
    loop.backend.start()
    rec = _Record(loop, finger, device, n)
    run(rec, loop, loop.clock, rec, total_frames=n, keep_running=loop.running, lead=0.0)
    return FFSimResult(**{key: v[:rec.k] for key, v in rec.cols.items()}, effects=[e.name for e in engine.effects],
                       name=name, buttons=engine.button_presses.names)


class _Record:
    """The simulation's touch source (the finger's reports, due at their delivery time) and its
    sink (records each tick, then hands the force to the loop, which steps the device)."""

    def __init__(self, loop: FFLoop, finger, device, n: int):
        self.loop, self.finger, self.device, self.k = loop, finger, device, 0
        self.cols = {"t": np.zeros(n), "load": np.zeros(n), "touched": np.zeros(n, dtype=bool),
                     "mask": np.zeros(n, dtype=np.int64), "button": np.full(n, -1, dtype=np.int64),
                     **{c: np.zeros((n, 3)) for c in ("force", "screen", "screen_v")},
                     **{c: np.zeros((n, 2)) for c in ("finger", "finger_v", "sliding", "finger_est")}}

    def deliver(self, until: float) -> None:
        self.finger.record_screen(until, self.device.p)
        for tr, x, y, ld, ts in self.finger.touches(until):
            self.loop.push_touch(0, x, y, ld, t_event=ts, t_arrival=tr)

    def emit(self, force: np.ndarray) -> None:
        c, k, t, dev, eng = self.cols, self.k, self.loop._t, self.device, self.loop.engine
        fx, fy = self.finger.position(t)
        fvx, fvy = self.finger.velocity(t)
        st = eng.state
        c["t"][k], c["force"][k], c["screen"][k], c["screen_v"][k] = t, force, dev.p, dev.v
        c["finger"][k], c["finger_v"][k] = (fx, fy), (fvx, fvy)
        c["sliding"][k], c["finger_est"][k] = (fvx - dev.v[0], fvy - dev.v[1]), (st.fx, st.fy)
        c["touched"][k], c["mask"][k], c["button"][k], c["load"][k] = st.touched, eng.mask, eng.button, \
            self.finger.load(t)
        self.k += 1
        self.loop.emit(force)


class OscFeedback:
    """60 Hz feedback to the tablet over OSC (callable for :class:`FFLoop` ``feedback``).

    Sends ``/surfhap/ff/screen x y z`` (m, device position), ``/surfhap/ff/offset dx dy``
    (m, shift the content by this to keep it still in the world) and
    ``/surfhap/ff/force fx fy fz`` (N, after the safety stage); with ``engine`` set (an
    :class:`surfhap.ff.engine.FFEngine` with GUI buttons) also ``/surfhap/ff/button index
    pressed name`` (int, 1 = pressed / 0 = released, str) once per press and per release.
    """

    def __init__(self, host: str, port: int, engine=None):
        from pythonosc.udp_client import SimpleUDPClient

        self.client = SimpleUDPClient(host, int(port))
        self.sent = 0
        self.engine = engine
        self._button = -1

    def __call__(self, t, px, py, pz, dx, dy, fx, fy, fz) -> None:
        c = self.client
        try:
            c.send_message("/surfhap/ff/screen", [px, py, pz])
            c.send_message("/surfhap/ff/offset", [dx, dy])
            c.send_message("/surfhap/ff/force", [fx, fy, fz])
            eng = self.engine
            b = -1 if eng is None else eng.button
            if b != self._button:  # one message per transition (a release, then a press)
                names = eng.button_presses.names
                if self._button >= 0:
                    c.send_message("/surfhap/ff/button", [self._button, 0, names[self._button]])
                if b >= 0:
                    c.send_message("/surfhap/ff/button", [b, 1, names[b]])
                self._button = b
            self.sent += 1
        except OSError:
            pass


class WorldTouchAdapter:
    """A touch-source target that takes *world* (content) positions, for trajectory replay.

    A trajectory file describes the finger in the world, as for ``ff simulate``; a tablet
    reports it on the moving screen. This adapter subtracts the device's current position
    (``backend.read``) before handing the sample to ``loop.push_touch``, so a replayed finger
    behaves like a real one (it stays put in the world while the screen moves under it).
    """

    def __init__(self, loop: FFLoop, backend: FFDevice):
        self.loop = loop
        self.backend = backend

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan,
                   t_arrival: float | None = None) -> bool:
        px, py, _, _ = self.backend.read(now())
        return self.loop.push_touch(source, x - px, y - py, load, t_event=t_event, t_arrival=t_arrival)
