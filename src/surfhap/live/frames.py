"""Engine side of the trace stream: what the page plots, packed at ``trace_hz``.

:class:`FrameBuilder` turns the engine's trace rows since its last call into a *frame*
(a dict of short lists, at most ``points`` long) and the engine status into a dict; both
are plain JSON-able values, sent in-process (:class:`surfhap.web.link.LocalLink`) or over
a pipe to the web process (:mod:`surfhap.web.process`).
"""

from __future__ import annotations

import numpy as np

from surfhap.live.session import backend_info

__all__ = ["FrameBuilder", "bin_rows"]

# trace columns of the engine (LiveEngine.trace): t, x, y, speed, load, drive V, target, friction
_COLUMNS = (("t", 0, 4), ("v", 5, 2), ("f", 7, 4), ("target", 6, 4), ("speed", 3, 4))  # key, column, decimals


def bin_rows(rows: np.ndarray, points: int) -> np.ndarray:
    """Trace ``rows`` (``(n, c) float``, c >= 8, see ``LiveEngine.trace``) binned to at most
    ``points`` rows (each bin: its last row, with the bin's peak drive voltage), NaN and
    infinities as 0: ``(m, c) float``, m <= points."""
    if rows.shape[0] > points:
        edges = np.linspace(0, rows.shape[0], points + 1).astype(int)
        keep = rows[edges[1:] - 1].copy()
        keep[:, 5] = np.maximum.reduceat(rows[:, 5], edges[:-1])
        rows = keep
    return np.nan_to_num(rows, nan=0.0, posinf=0.0, neginf=0.0)


class FrameBuilder:
    """The rows an engine wrote since the last :meth:`frame`, and its status."""

    def __init__(self, engine, backend, points: int = 64):
        self.engine, self.backend, self.points = engine, backend, int(points)
        self._idx = 0

    def frame(self) -> dict:
        """The next frame: the trace rows since the last call (at most half the trace ring),
        :func:`bin_rows` and rounded: ``{"t": s, "v": V, "f": N, "target": N, "speed": m/s}``,
        lists of equal length. An engine whose ``frame_extra`` is a method (the force-feedback
        view, :class:`surfhap.web.ff.FFWebEngine`; the texture engine's is None) adds its part
        of the same binned rows under ``"ff"``."""
        eng = self.engine
        rows, self._idx = eng.trace_since(self._idx, limit=eng.trace.shape[0] // 2)
        r = bin_rows(rows, self.points)
        frame = {key: np.round(r[:, col], dec).tolist() for key, col, dec in _COLUMNS}
        if eng.frame_extra is not None:
            frame["ff"] = eng.frame_extra(r)
        return frame

    def status(self) -> dict:
        """``engine.status()`` with the output backend's info under ``"output"``."""
        st = self.engine.status()
        st["output"] = backend_info(self.backend)
        return st
