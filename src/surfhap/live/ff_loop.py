"""The live force-feedback loop: a 1 kHz haptic thread and a 60 Hz position-feedback thread.

Real-time contract of the haptic thread (004 Sec. 4.2: "a haptic thread running at about
1000 Hz" and "an additional 60 Hz thread ... to send the Falcon position to the tablet"):

* every tick (period ``1/rate``): drain the touch ring (bounded), read the device position,
  run :class:`surfhap.ff.engine.FFEngine` (kinematics, effects, control law, safety stage)
  and write the force to the device backend. Nothing in a tick sleeps, logs, allocates
  arrays or takes a lock that a producer holds for long;
* ticks are scheduled on absolute deadlines by :class:`surfhap.live.pacing.Pacer` (sleep to
  just before the deadline, spin the rest; no drift); a tick that starts more than one period
  late counts the periods it skipped as *missed* and re-anchors the schedule. The thread asks
  for ``SCHED_FIFO`` (:func:`surfhap.live.pacing.enter_realtime`; the mode granted is in
  :meth:`FFLoop.stats` as ``scheduling``, a refusal is logged once);
* the period error (start time minus deadline) of every tick is kept in a preallocated
  ring for the statistics (:meth:`FFLoop.stats`);
* stop (Ctrl-C, SIGTERM, ``request_stop``): the safety stage ramps the lateral force to zero at
  its slew rate and puts the tablet down (weight compensation lowered over its ``land_time``),
  the loop runs until the output is zero (at most ``stop_timeout``), then writes one zero
  force and ends;
* failure: an exception anywhere in a tick (touch drain, device read / write, an effect) is
  kept in ``error`` and turns into a stop: the tick still runs the safety stage, so the output
  ramps down within its limits (the command exits 3).

The feedback thread sends, at ``feedback_rate``, the device position and the content offset
(``-X_t``, so the tablet draws the content still in the world) to ``feedback(...)``,
a callable (an OSC sender, see :class:`OscFeedback`).

Touch samples reach the loop through :meth:`FFLoop.push_touch`, the same call the existing
touch sources use (:class:`surfhap.live.sources.OscTouchSource`, ``ReplaySource``).
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
from surfhap.runtime.clock import STALE, arrival_stamp, now, sleep_until
from surfhap.live.ff_devices import FFDevice
from surfhap.live.pacing import SPIN, Pacer, enter_realtime
from surfhap.live.queues import TouchRing

__all__ = ["FFLoop", "OscFeedback", "FFLoopStats", "WorldTouchAdapter"]

log = logging.getLogger("surfhap.live")


class FFLoopStats(dict):
    """Loop statistics (a dict, JSON-ready): ticks, missed, period error percentiles (ms), ..."""


class FFLoop:
    """Run ``engine`` against ``backend`` at ``rate`` Hz in a thread.

    engine        : :class:`surfhap.ff.engine.FFEngine`.
    backend       : device backend (:class:`surfhap.live.ff_devices.FFDevice`).
    feedback      : callable ``(t, px, py, pz, dx, dy, fx, fy, fz)`` at ``feedback_rate`` Hz, or None.
    stop_timeout  : s, longest ramp-down on stop (default: the safety stage's landing and ramp).
    history       : ticks of period error kept for the statistics.
    clock         : the time base of touch arrival stamps (default :func:`now`; tests driving
                    :meth:`tick_once` pass their simulated clock).
    realtime      : ask for real-time scheduling of the haptic thread (see :mod:`surfhap.live.pacing`).
    """

    def __init__(self, engine: FFEngine, backend: FFDevice, *, feedback=None, feedback_rate: float = 60.0,
                 stop_timeout: float | None = None, history: int = 1 << 17, spin: float = SPIN, clock=now,
                 realtime: bool = True):
        self.engine = engine
        self.clock = clock
        self.backend = backend
        self.rate = engine.rate
        self.period = 1.0 / self.rate
        self.feedback = feedback
        self.feedback_rate = float(feedback_rate)
        # long enough for the safety stage to put the tablet down and ramp to zero
        self.stop_timeout = engine.safety.stop_duration + 0.1 if stop_timeout is None else float(stop_timeout)
        self.spin = float(spin)
        self.realtime = bool(realtime)
        self.scheduling = "not started"
        self._switch: float | None = None
        self.touches = TouchRing(1024)
        self.touches_stale = 0
        self._buf = np.zeros((64, 6))
        self._err = np.zeros(int(history))
        self.ticks = 0
        self.missed = 0
        self._stop = threading.Event()
        self.done = threading.Event()
        self._thread = None
        self._fb_thread = None
        # px, py, pz, fx, fy, fz, active-effect mask, pressed button of the last tick (tuple store: atomic)
        self._last = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, -1)
        self.feedback_snapshot = self._last  # the tick the feedback thread is reporting (read it from feedback)
        self.error = None
        self._stop_left = None  # ticks left for the stop ramp (None = not stopping)

    # ------------------------------------------------------------- producers
    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan,
                   t_arrival: float | None = None) -> bool:
        """Hand one validated touch sample to the loop (any thread). x, y m; load N (0 = lifted).

        The loop stamps the arrival itself on its clock; a caller's ``t_arrival`` can only make
        the sample older (:func:`surfhap.runtime.clock.arrival_stamp`, the law the texture engine
        uses too). A future or non-finite ``t_arrival`` is stale: counted in ``touches_stale``
        and dropped."""
        ta = arrival_stamp(t_arrival, self.clock())
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
        # the objects alive now (modules, numpy, numba: ~10^5) are never scanned again by the
        # cyclic collector: a full collection over them stalls whichever thread runs it for
        # 50-100 ms, the haptic thread included (unfrozen on stop)
        gc.freeze()
        warm_up()  # the compiled tick, before the first deadline
        self.engine.reset()
        self._stop_left = None
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

    # ------------------------------------------------------------- threads
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

    def tick_once(self, t: float) -> bool:
        """One haptic tick at time ``t`` (s, the loop's ``clock``): drain the touches, read the
        device (its stamp through :func:`arrival_stamp`), tick the engine (its safety stage runs on every tick, also after an exception)
        and write the force. False once a stop has ramped to zero (or used its
        ``stop_timeout`` worth of ticks: counted in ticks, so a stalled loop still ramps). The
        thread calls it on its deadlines; tests call it directly with a simulated clock."""
        eng, be = self.engine, self.backend
        px = py = pz = t_pos = math.nan
        try:
            self._drain()
        except Exception as exc:  # noqa: BLE001 - the device is still read: the stop lands the tablet
            self._fail(exc)
        try:
            px, py, pz, t_pos = be.read(t)
        except Exception as exc:  # noqa: BLE001 - no position: the safety stage ramps to zero
            self._fail(exc)
        # the one arrival law (runtime/clock.py), as for touches: the device's stamp may only make
        # the position older than its hand-over; a future or non-finite one is STALE
        t_pos = arrival_stamp(t_pos, self.clock())
        if self._stop.is_set() and self._stop_left is None:
            eng.stop()
            self._stop_left = math.ceil(self.stop_timeout * self.rate)
        saf = eng.safety
        ticks = saf.n_ticks
        try:
            f = eng.tick(t, px, py, pz, t_pos)
        except Exception as exc:  # noqa: BLE001 - outside the control law: the safety stage alone
            self._fail(exc)
            eng.stop()
            if saf.n_ticks == ticks:  # the tick failed before the safety stage took this tick's position
                try:
                    saf.observe(t, t_pos, px, py, pz)
                except Exception:  # noqa: BLE001 - unusable position: the stop below still ramps
                    pass
            f = saf.limit(0.0, 0.0, 0.0, True)  # this tick's clock advanced once: a ramp, never a jump
        if eng.error is not None:
            self._fail(eng.error)
        try:
            be.write(f, t)
        except Exception as exc:  # noqa: BLE001
            self._fail(exc)
        self._last = (px, py, pz, float(f[0]), float(f[1]), float(f[2]), int(eng.mask), eng.button)
        if self._stop_left is not None:
            self._stop_left -= 1
            if (f[0] == 0.0 and f[1] == 0.0 and f[2] == 0.0) or self._stop_left <= 0:
                return False
        return True

    def _run(self) -> None:
        self.scheduling = enter_realtime() if self.realtime else "normal"
        err, n_err = self._err, self._err.shape[0]
        pacer = Pacer(self.period, spin=self.spin)
        try:
            go = True
            while go:
                t, late, skipped = pacer.wait()
                err[self.ticks % n_err] = late
                self.ticks += 1
                self.missed += skipped
                go = self.tick_once(t)
        except Exception as exc:  # noqa: BLE001 - the safety stage itself failed: last resort below
            self._fail(exc)
        finally:
            try:
                self.backend.write(np.zeros(3), now())
            except Exception:  # noqa: BLE001
                log.debug("ff: could not write the final zero force", exc_info=True)
            self.done.set()

    def _run_feedback(self) -> None:
        period = 1.0 / self.feedback_rate
        deadline = now()
        while not self.done.is_set():
            deadline += period
            self._send_feedback(sleep_until(deadline, 0.0))
        self._send_feedback(now())  # the final state (the force at zero after the stop) reaches the tablet too

    def _send_feedback(self, t: float) -> None:
        snap = self.feedback_snapshot = self._last
        px, py, pz, fx, fy, fz = snap[:6]
        try:
            self.feedback(t, px, py, pz, -px, -py, fx, fy, fz)
        except Exception:  # noqa: BLE001 - feedback is best effort
            log.debug("ff feedback failed", exc_info=True)

    # ------------------------------------------------------------- results
    def stats(self) -> FFLoopStats:
        """Period-error distribution (ms), missed ticks, engine and safety counters."""
        n = min(self.ticks, self._err.shape[0])
        e = self._err[:n] * 1e3
        pct = (lambda q: float(np.percentile(e, q)) if n else 0.0)
        c = self.engine.safety.counters
        return FFLoopStats(
            ticks=self.ticks, missed=self.missed, rate_hz=self.rate,
            period_error_ms={"p50": pct(50), "p99": pct(99), "p999": pct(99.9), "max": float(e.max()) if n else 0.0},
            touches_received=self.touches._write, touches_dropped=self.touches.dropped,
            touches_stale=self.touches_stale + self.engine.touch_stale, touches_rejected=self.engine.touch_rejected,
            safety={"clamped": c.clamped, "slew_limited": c.slew_limited, "faults": c.faults,
                    "device_lost": c.device_lost, "workspace": c.workspace, "stopped": c.stopped,
                    "stale": c.stale, "rejected": c.rejected, "braked": c.braked},
            device=self.backend.info(), scheduling=self.scheduling,
            error=None if self.error is None else repr(self.error),
        )


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
