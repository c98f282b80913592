"""Offline closed loop: force-feedback engine + simulated device + simulated finger.

:func:`simulate_ff` runs the very engine the live loop runs, tick by tick at its rate, on
the simulated clock: touch reports reach the engine when the simulated tablet delivers
them, the engine's force (after the safety stage) goes to the simulated device through the
device gain, and the finger presses and drags the screen.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from surfhap.results import Result, jsonable
from surfhap.sim.ff_device import SimDevice, SimFinger

__all__ = ["FFSimResult", "simulate_ff"]


@dataclass
class FFSimResult(Result):
    """Per-tick record of a simulation (n ticks).

    t (n,) s; force (n, 3) N (safe force, device frame); screen (n, 3) m and screen_v (n, 3)
    m/s (X_t relative to X0); finger (n, 2) m and finger_v (n, 2) m/s in the world;
    sliding (n, 2) m/s finger velocity relative to the screen; finger_est (n, 2) m the
    engine's estimate of the finger's world position; touched (n,) bool; mask (n,) int
    (bit i = effect i active); load (n,) N; effects: effect names by bit; button (n,) int
    the GUI button being pressed (-1 = none) and buttons: button names by index.
    """

    t: np.ndarray
    force: np.ndarray
    screen: np.ndarray
    screen_v: np.ndarray
    finger: np.ndarray
    finger_v: np.ndarray
    sliding: np.ndarray
    finger_est: np.ndarray
    touched: np.ndarray
    mask: np.ndarray
    load: np.ndarray
    effects: list[str] = field(default_factory=list)
    name: str = "ff simulation"
    button: np.ndarray | None = None
    buttons: list[str] = field(default_factory=list)

    def presses(self) -> list[tuple[float, str]]:
        """(time s, button name) of every press event."""
        if self.button is None or not self.buttons:
            return []
        idx = np.nonzero((self.button >= 0) & (np.diff(self.button, prepend=-1) != 0))[0]
        return [(float(self.t[i]), self.buttons[int(self.button[i])]) for i in idx]

    def switches(self) -> list[tuple[float, list[str]]]:
        """(time s, active effect names) at every change of the active set ([] = idle)."""
        idx = np.nonzero(np.diff(self.mask, prepend=-1))[0]
        return [(float(self.t[i]), [n for b, n in enumerate(self.effects) if int(self.mask[i]) >> b & 1]) for i in idx]

    panels = 4

    def summary(self) -> dict:
        touch = self.touched
        slide = np.hypot(self.sliding[:, 0], self.sliding[:, 1])
        fing = np.hypot(self.finger_v[:, 0], self.finger_v[:, 1])
        rms = (lambda a: float(np.sqrt(np.mean(a ** 2))) if a.size else 0.0)
        return jsonable({
            "name": self.name,
            "ticks": int(self.t.size),
            "duration_s": float(self.t[-1] - self.t[0]) if self.t.size else 0.0,
            "touched_fraction": float(np.mean(touch)) if touch.size else 0.0,
            "force_abs_max_N": [float(v) for v in np.abs(self.force).max(axis=0)],
            "screen_range_m": [float(v) for v in np.ptp(self.screen, axis=0)],
            "finger_speed_rms_m_s": rms(fing[touch]),
            "sliding_speed_rms_m_s": rms(slide[touch]),
            "switches": len(self.switches()),
            "effects": list(self.effects),
            **({"button_presses": [{"t_s": round(t, 4), "button": b} for t, b in self.presses()]}
               if self.buttons else {}),
        })

    def plot(self, ax=None):
        """Forces, screen motion, relative sliding and effect switches (matplotlib Figure)."""
        from surfhap.report.ff_figures import plot_ff_result

        return plot_ff_result(self, ax)


def simulate_ff(engine, finger: SimFinger, device: SimDevice, settle: float = 0.3, tail: float = 0.2,
                name: str = "ff simulation") -> FFSimResult:
    """Run ``engine`` against ``device`` and ``finger`` from ``settle`` s before the finger's
    trajectory to ``tail`` s after it; returns the per-tick record.

    The device's gain must match the engine's ``device.gain`` (the backend multiplies the
    safe force by it, the device divides its command by it)."""
    rate = engine.rate
    dt = 1.0 / rate
    if abs(device.rate - rate) > 1e-9:
        raise ValueError("device and engine rates differ")
    t0 = finger.t0 - settle
    n = int(round((finger.t1 + tail - t0) * rate)) + 1
    t = t0 + np.arange(n) * dt
    rec = {k: np.zeros((n, 3 if k.startswith(("force", "screen")) else 2))
           for k in ("force", "screen", "screen_v", "finger", "finger_v", "sliding", "finger_est")}
    touched = np.zeros(n, dtype=bool)
    mask = np.zeros(n, dtype=np.int64)
    button = np.full(n, -1, dtype=np.int64)
    load = np.zeros(n)
    gain = engine.device.gain
    cmd = np.zeros(3)
    engine.reset()
    st = engine.state
    for k in range(n):
        tk = float(t[k])
        p = device.p
        finger.record_screen(tk, p)
        for tr, x, y, ld, ts in finger.touches(tk):
            engine.touch(tr, x, y, ld, t_event=ts)
        f = engine.tick(tk, float(p[0]), float(p[1]), float(p[2]), tk)
        cmd[0], cmd[1], cmd[2] = f[0] * gain, f[1] * gain, f[2] * gain
        rec["force"][k] = f
        rec["screen"][k] = p
        rec["screen_v"][k] = device.v
        rec["finger"][k] = finger.position(tk)
        rec["finger_v"][k] = fv = finger.velocity(tk)
        rec["sliding"][k] = (fv[0] - device.v[0], fv[1] - device.v[1])
        rec["finger_est"][k] = (st.fx, st.fy)
        touched[k] = st.touched
        mask[k] = engine.mask
        button[k] = engine.button
        load[k] = finger.load(tk)
        device.step(cmd, finger.force_on_screen(tk, device.v))
    return FFSimResult(t, rec["force"], rec["screen"], rec["screen_v"], rec["finger"], rec["finger_v"], rec["sliding"],
                       rec["finger_est"], touched, mask, load, [e.name for e in engine.law.effects], name,
                       button, engine.button_presses.names)
