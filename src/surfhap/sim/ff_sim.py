"""The record of an offline force-feedback run (``ff simulate``): the loop itself is the live
one on a simulated clock (:func:`surfhap.live.ff_loop.simulate_ff`), with the simulated device
and finger of :mod:`surfhap.sim.ff_device`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from surfhap.results import Result, jsonable

__all__ = ["FFSimResult"]


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
