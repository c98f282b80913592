"""The force-feedback page: the touch page's router (:mod:`surfhap.web.touch`) over the
force-feedback loop. :class:`FFWebEngine` offers what the page server uses of an engine
(``push_touch``, ``warm_up``, ``status``, ``trace_since``, rates) over an
:class:`~surfhap.live.ff_loop.FFLoop`: touches go into the haptic loop (page positions span
the whole scene, ``positions="surface"``), the scene's picture is the preview, and the trace
shows the finger speed and, in the drive slot, the force magnitude sent to the device (N; the
scale's maximum is the force limit), sampled by the 60 Hz feedback thread.

Force-feedback panel: each trace frame carries ``"ff": {"p": [[x, y, z], ...], "F": [[fx, fy,
fz], ...], "mask": [...], "button": [...]}`` (one entry per trace point): the device position
(m, relative to the workspace centre X0), the force after the safety stage (N, device frame:
x along the display's width, y along its height, z normal to it, towards the user), the
active-effect mask and the pressed button; ``/api/info`` carries the device's limits and the
effect and button names under ``"ff"`` (:func:`ff_page_info`).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from surfhap.live.queues import ring_rows_since

__all__ = ["FFWebEngine", "FFWebBackend", "build_ff_session", "ff_page_info"]

# t, x, y, speed, load, |F| (in the page's drive slot), Fz, Fx, then for the ff panel:
# px, py, pz (m), Fx, Fy, Fz (N), active-effect mask, pressed button (index, -1 = none)
_TRACE_COLS = 16
_P, _F, _MASK, _BUTTON = slice(8, 11), slice(11, 14), 14, 15


class FFWebEngine:
    """Engine-shaped view of an FFLoop for the page server."""

    def __init__(self, loop, f_max: float):
        self.loop = loop
        self.drive_rate = loop.rate
        self.control_rate = loop.rate
        self.block_period = loop.period
        self.drive_full_scale = float(f_max)  # N: the trace's drive column is |F|
        self.drive_unit = "N"
        self.trace = np.zeros((1024, _TRACE_COLS))
        self.trace_count = 0
        self._lock = threading.Lock()

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan,
                   t_arrival: float | None = None) -> bool:
        return self.loop.push_touch(source, x, y, load, t_event=t_event, t_arrival=t_arrival)

    def warm_up(self) -> None:
        """Nothing to do here: the force loop compiles its tick (``tick_kernel.warm_up``) when it
        starts, before its first deadline."""

    def record(self, t, px, py, pz, fx, fy, fz, mask: int | None = None, button: int | None = None) -> None:
        """One trace row (called by the feedback thread): device position px, py, pz (m) and
        safe force fx, fy, fz (N) of one haptic tick; ``mask`` / ``button`` default to those of
        the same tick (the loop's ``feedback_snapshot``), so a row never pairs a position with
        a newer button state."""
        eng = self.loop.engine
        st = eng.state
        snap = self.loop.feedback_snapshot
        if mask is None:
            mask = snap[6] if snap is not None else eng.mask
        if button is None:
            button = snap[7] if snap is not None else eng.button
        with self._lock:
            row = self.trace[self.trace_count & (self.trace.shape[0] - 1)]
            row[:] = (t, st.fx, st.fy, st.speed, st.load if st.touched else 0.0, math.sqrt(fx * fx + fy * fy + fz * fz),
                      fz, fx, px, py, pz, fx, fy, fz, mask, button)
            self.trace_count += 1

    def frame_extra(self, rows: np.ndarray) -> dict:
        """The ff panel's part of a trace frame for these binned (n, 16) trace rows:
        ``{"p": (n, 3) m, "F": (n, 3) N, "mask": (n,) int, "button": (n,) int}`` as lists."""
        return {"p": np.round(rows[:, _P], 6).tolist(), "F": np.round(rows[:, _F], 4).tolist(),
                "mask": rows[:, _MASK].astype(int).tolist(), "button": rows[:, _BUTTON].astype(int).tolist()}

    def trace_since(self, index: int, limit: int | None = None):
        with self._lock:
            return ring_rows_since(self.trace, self.trace_count, index, limit)

    def status(self) -> dict:
        st = dict(self.loop.stats())
        st["counters"] = {"ticks": st["ticks"], "missed": st["missed"], "touches_dropped": st["touches_dropped"]}
        return st


class FFWebBackend:
    """Backend-shaped view: starting / stopping the session starts / stops the loop."""

    name = "ff"

    def __init__(self, loop):
        self.loop = loop

    def start(self, engine) -> None:
        self.loop.start()

    def stop(self) -> None:
        self.loop.stop()

    def info(self) -> dict:
        be = self.loop.backend
        return {"name": f"ff:{be.name}", **be.info()}


def build_ff_session(scene, loop, f_max: float):
    """A :class:`surfhap.live.session.LiveSession` whose engine is ``loop`` (see module doc).

    Chain the returned session's ``engine.record`` into the loop's feedback for the trace.
    """
    from surfhap.live.session import LiveSession
    from surfhap.live.sources import TouchSpace

    pic = scene.picture_array(256)
    lo, hi = float(np.min(pic)), float(np.max(pic))
    data = (pic - lo) / (hi - lo) if hi > lo else np.full(pic.shape, 0.5)
    preview = {"w": int(pic.shape[1]), "h": int(pic.shape[0]),
               "data": np.round(255 * data).astype(int).ravel().tolist()}
    w, h = scene.size
    eng = FFWebEngine(loop, f_max)
    return LiveSession(eng, FFWebBackend(loop), title=f"ff: {scene.name}", preview=preview,
                       space=TouchSpace(width=w, height=h), positions="surface", ff=ff_page_info(scene, loop))


def ff_page_info(scene, loop) -> dict:
    """What the page's force-feedback panel needs once (JSON-ready): the device's workspace
    half-sizes (m) and force limits (N) per axis, the effect names by mask bit and the
    button names by index."""
    dev = loop.engine.device
    return {"device": dev.name, "workspace_m": list(dev.workspace), "f_max_n": list(dev.f_max),
            "effects": [e.name for e in loop.engine.effects],
            "buttons": [b.name for b in scene.buttons]}
