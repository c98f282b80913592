"""What the render figure shows, kept in bounded memory while a render streams.

:class:`PreviewRecorder` takes the control-rate and drive-rate blocks of a render as they are
produced and keeps only: a 1 s window of friction, target and low band in the middle of the
render; a 50 ms window of the drive and its envelope there; up to ``spectrum_seconds`` of
added friction (after the 0.5 s settling) for the spectrum; and a min/max envelope of speed
and load with at most ``columns`` columns (one per pixel column of the figure). Its memory
does not depend on the render's duration. ``finish()`` returns a :class:`RenderPreview`,
which :func:`surfhap.report.figures.plot_render` draws.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from surfhap.render.drive import rendering_gain
from surfhap.render.expected import expected_texture_psd

__all__ = ["PreviewRecorder", "RenderPreview"]

SETTLE_S = 0.5  # s skipped before the spectrum (filter start-up)


@dataclass
class RenderPreview:
    """Bounded copies of a render for its figure (arrays float64; times in s).

    win_t, win_friction, win_target, win_mu_low, win_load: (w,) the middle window, N and N.
    win_low: (w,) N, the drive law's low-band target there (its ``LowBand``: mu_low times the
    load the method uses, Zhao's constant load for zhao), which the figure's law line draws.
    drv_t, drv: (d,) drive window, V; env_t, env: (e,) envelope in that window, V.
    spec_added: (s,) N added friction from ``SETTLE_S`` on, at ``control_rate`` (spectrum input).
    col_t, speed_min, speed_max, load_min, load_max: (c,) min/max envelope per column.
    expected_psd: freqs (k,) Hz -> (k,) N^2/Hz or None, the texture model's spectrum.
    """

    material: str
    method: str
    carrier: float
    rendering_gain: float
    mu_panel: float
    control_rate: int
    texture_rate: int | None
    span: float
    window: float
    win_t: np.ndarray
    win_friction: np.ndarray
    win_target: np.ndarray
    win_mu_low: np.ndarray
    win_load: np.ndarray
    win_low: np.ndarray
    drv_t: np.ndarray
    drv: np.ndarray
    env_t: np.ndarray
    env: np.ndarray
    spec_added: np.ndarray
    col_t: np.ndarray
    speed_min: np.ndarray
    speed_max: np.ndarray
    load_min: np.ndarray
    load_max: np.ndarray
    expected_psd: Callable[[np.ndarray], np.ndarray | None]


def _index_window(lo_s: float, hi_s: float, rate: float, n: int) -> tuple[int, int]:
    """Sample indices [a, b) whose times i / rate lie in [lo_s, hi_s]."""
    a = max(0, math.ceil(lo_s * rate - 1e-9))
    b = min(n, math.floor(hi_s * rate + 1e-9) + 1)
    return a, max(a, b)


class _Window:
    """A preallocated copy of samples [a, b) of a stream fed in consecutive blocks."""

    def __init__(self, a: int, b: int):
        self.a, self.b = a, b
        self.buf = np.zeros(b - a)

    def add(self, start: int, block: np.ndarray) -> None:
        lo, hi = max(self.a, start), min(self.b, start + block.shape[0])
        if hi > lo:
            self.buf[lo - self.a:hi - self.a] = block[lo - start:hi - start]


class PreviewRecorder:
    """Collects a :class:`RenderPreview` from blocks; memory independent of the duration.

    n_model: model samples the render will have; n_drive: drive samples it will have (an
    estimate is fine: it only places the drive window); low_band: the drive law's
    :class:`~surfhap.render.drive.LowBand` (None: no law line).
    """

    def __init__(self, n_model: int, n_drive: int, control_rate: int, drive_rate: int, low_band,
                 *, columns: int = 1200, spectrum_seconds: float = 30.0):
        self.n, self.fm, self.fd, self.low_band = n_model, control_rate, drive_rate, low_band
        t_last = (n_model - 1) / control_rate if n_model else 0.0
        self.span = min(1.0, t_last) if n_model else 1.0
        start = max(0.0, t_last / 2 - self.span / 2)
        a, b = _index_window(start, start + self.span, control_rate, n_model)
        self._win = {k: _Window(a, b) for k in ("friction", "target", "mu_low", "load", "low")}
        td_last = (n_drive - 1) / drive_rate if n_drive else 0.0
        self.window = min(0.05, td_last) if n_drive else 0.05
        mid = td_last / 2
        self._drv = _Window(*_index_window(mid, mid + self.window, drive_rate, n_drive))
        self._env = _Window(*_index_window(mid, mid + self.window, control_rate, n_model))
        s0 = min(int(SETTLE_S * control_rate), max(0, n_model - 64))
        s1 = min(n_model, s0 + int(spectrum_seconds * control_rate))
        self._spec = {k: _Window(s0, s1) for k in ("friction", "load", "speed")}
        self._bin = max(1, math.ceil(n_model / columns))
        ncol = math.ceil(n_model / self._bin)
        self._cols = {k: np.full(ncol, np.inf if k.endswith("min") else -np.inf)
                      for k in ("speed_min", "speed_max", "load_min", "load_max")}

    def add_model(self, start: int, speed: np.ndarray, load: np.ndarray, target: np.ndarray,
                  mu_low: np.ndarray, voltage: np.ndarray) -> None:
        """Model-rate block (n,) starting at model sample ``start``."""
        for key, arr in (("target", target), ("mu_low", mu_low), ("load", load)):
            self._win[key].add(start, arr)
        w = self._win["low"]
        lo, hi = max(w.a, start) - start, min(w.b, start + load.shape[0]) - start  # the law line of the window only
        if self.low_band is not None and hi > lo:
            w.add(start + lo, self.low_band.force(load[lo:hi], mu_low[lo:hi]))
        self._env.add(start, voltage)
        self._spec["load"].add(start, load)
        self._spec["speed"].add(start, speed)
        n = speed.shape[0]
        if not n:
            return
        first, last = start // self._bin, (start + n - 1) // self._bin
        edges = np.arange(first + 1, last + 1) * self._bin - start
        idx = np.concatenate(([0], edges))
        for name, arr in (("speed", speed), ("load", load)):
            lo, hi = self._cols[name + "_min"], self._cols[name + "_max"]
            lo[first:last + 1] = np.minimum(lo[first:last + 1], np.minimum.reduceat(arr, idx))
            hi[first:last + 1] = np.maximum(hi[first:last + 1], np.maximum.reduceat(arr, idx))

    def add_friction(self, start: int, friction: np.ndarray) -> None:
        """Simulated friction (n,) N starting at model sample ``start``."""
        self._win["friction"].add(start, friction)
        self._spec["friction"].add(start, friction)

    def add_drive(self, start: int, drive: np.ndarray) -> None:
        """Drive samples (m,) V starting at drive sample ``start``."""
        self._drv.add(start, drive)

    def finish(self, m, n_done: int) -> RenderPreview:
        """The preview of render ``m`` (its settings: material, method, carrier, ...) after
        ``n_done`` model samples (windows beyond them are cut if the render stopped early)."""
        n = n_done

        def cut(w: _Window, limit: int) -> tuple[np.ndarray, np.ndarray]:
            b = max(w.a, min(w.b, limit))
            return np.arange(w.a, b), w.buf[:b - w.a]

        idx, fr = cut(self._win["friction"], n)
        wt = idx / self.fm
        di, dv = cut(self._drv, int(n * self.fd / self.fm))
        ei, ev = cut(self._env, n)
        _, sf = cut(self._spec["friction"], n)
        _, sl = cut(self._spec["load"], n)
        _, ss = cut(self._spec["speed"], n)
        ncol = math.ceil(n / self._bin) if n else 0

        def psd(freqs):  # at the median speed and load while touching, found when asked
            touching = sl > 0
            if not np.any(touching):
                return None
            return expected_texture_psd(m, freqs, float(np.median(ss[touching])), float(np.median(sl[touching])))

        k = len(wt)
        return RenderPreview(
            material=m.material, method=m.method, carrier=m.carrier, rendering_gain=rendering_gain(m.alpha, m.alpha_calibrated),
            mu_panel=m.mu_panel, control_rate=self.fm, texture_rate=m.texture_rate, span=self.span, window=self.window,
            win_t=wt, win_friction=fr, win_target=self._win["target"].buf[:k], win_mu_low=self._win["mu_low"].buf[:k],
            win_load=self._win["load"].buf[:k], win_low=self._win["low"].buf[:k], drv_t=di / self.fd, drv=dv, env_t=ei / self.fm, env=ev,
            spec_added=sf - m.mu_panel * sl, col_t=np.arange(ncol) * self._bin / self.fm,
            speed_min=self._cols["speed_min"][:ncol], speed_max=self._cols["speed_max"][:ncol],
            load_min=self._cols["load_min"][:ncol], load_max=self._cols["load_max"][:ncol], expected_psd=psd,
        )

