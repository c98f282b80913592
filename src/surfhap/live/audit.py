"""An auditor of emitted drive streams, independent of the engine's own bookkeeping: the
reference check of the safety promise (tests, benchmarks, the live server's self-test)."""

from __future__ import annotations

import numpy as np

__all__ = ["audit_drive"]


def audit_drive(drive: np.ndarray, drive_rate: float, limits, touch_age: np.ndarray | None = None,
                silent: np.ndarray | None = None, prev: float = 0.0) -> dict:
    """Count safety violations in an emitted drive stream (volts, shape (n,)), independently
    of the engine's own bookkeeping:

    * ``over_v_max``: samples with ``|V| > v_max``;
    * ``rise_too_fast``: magnitude rises beyond ``rise_rate / drive_rate`` per sample (the
      stream starts from magnitude ``prev``, 0 V by default);
    * ``non_finite``: NaN or infinite samples;
    * ``watchdog`` (when ``touch_age`` is given: (n,) s, age of the freshest touch sample at
      each sample's emission, ``inf`` if none): nonzero samples whose touch data is older
      than ``watchdog_timeout + watchdog_ramp``;
    * ``not_silent`` (when ``silent`` is given: (n,) bool, samples that must be 0 V, e.g.
      after a stop ramp): nonzero samples among them.

    A 1e-9 V tolerance covers rounding. ``violations`` is the sum.
    """
    raw = np.asarray(drive, dtype=float)
    d = np.abs(raw)
    over = int(np.count_nonzero(d > limits.v_max + 1e-9))
    step = limits.rise_rate / drive_rate
    rise = int(np.count_nonzero(np.diff(np.concatenate(([abs(prev)], d))) > step + 1e-9)) if d.size else 0
    nonfinite = int(np.count_nonzero(~np.isfinite(raw)))
    wd = 0
    if touch_age is not None:
        age = np.asarray(touch_age, dtype=float)
        stale = ~(age <= limits.watchdog_timeout + limits.watchdog_ramp)  # NaN counts as stale
        wd = int(np.count_nonzero(stale & (d != 0.0)))
    loud = 0
    if silent is not None:
        loud = int(np.count_nonzero(np.asarray(silent, dtype=bool) & (d != 0.0)))
    return {"over_v_max": over, "rise_too_fast": rise, "non_finite": nonfinite, "watchdog": wd,
            "not_silent": loud, "violations": over + rise + nonfinite + wd + loud}
