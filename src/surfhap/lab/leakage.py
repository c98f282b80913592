"""Charge-leakage time constant of an electrostatic display from DC-drive tribometer recordings.

Charge leaks through the skin, so a constant (DC) drive attracts the finger less and less: the
finger/insulator stack acts as a first-order high-pass with time constant tau (the
residual-charge effect that makes Otake et al. switch the polarity; the model of
:mod:`surfhap.models.panel`). After a DC step to V the effective voltage is ``V exp(-t/tau)`` and
the friction increase ``mu k V^2 exp(-2 t / tau)``.

Method (surfhap's; the papers do not measure it): the lateral force minus ``mu fn`` (mu from
the drive-off stretches) is low-passed (80 Hz, zero phase, to remove the vibration), the
stretches around each switch-on are averaged, and the model ``A exp(-2 t / tau) + c`` after
the onset (0 before it), passed through the same low-pass, is fitted by bounded least
squares, so the filter's smearing of the onset does not bias tau. The recordings must use a DC drive (no
polarity carrier) with on-stretches several tau long.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from surfhap.errors import ConfigError
from surfhap.exchange.tribometer import TribometerRecording

__all__ = ["LeakageFit", "fit_leakage"]

LOWPASS_HZ = 80.0  # removes the vibration (Kim et al.'s grains: > 100 Hz) (design choice)
PRE_S = 0.05  # s before each onset included in the fit (drive off: no increase)
EDGE_S = 0.02  # s at both ends of the window left out (edges of the model's filtering)
MIN_DECAY = 0.5  # the decaying part must be at least half of the onset increase (design choice)


@dataclass(frozen=True)
class LeakageFit:
    """time_constant: s (mean over recordings); per_recording (r,) s; t (m,) s and
    profile (m,) N: the averaged onset of the first recording with its fit ``model`` (m,)."""

    time_constant: float
    per_recording: np.ndarray
    t: np.ndarray
    profile: np.ndarray
    model: np.ndarray


def _step_decay(t: np.ndarray, a: float, tau: float, c: float) -> np.ndarray:
    """The friction increase after a DC step at t = 0: a exp(-2 t / tau) + c, 0 before it."""
    return np.where(t >= 0, a * np.exp(-2.0 * np.maximum(t, 0.0) / tau) + c, 0.0)


def fit_leakage(recordings: Sequence[TribometerRecording]) -> LeakageFit:
    """Leakage time constant from DC-drive recordings (see the module docstring)."""
    from scipy.optimize import curve_fit
    from scipy.signal import butter, sosfiltfilt

    taus, first = [], None
    for rec in recordings:
        on = rec.on
        off = ~on
        mu = float(rec.lateral_force[off].sum() / max(rec.normal_force[off].sum(), 1e-12))
        if rec.sample_rate <= 4 * LOWPASS_HZ:
            raise ConfigError(f"sample rate must exceed {4 * LOWPASS_HZ:g} Hz", source=rec.source, field="time")
        sos = butter(4, LOWPASS_HZ, fs=rec.sample_rate, output="sos")
        d = sosfiltfilt(sos, rec.lateral_force - mu * rec.normal_force)
        pre = int(round(PRE_S * rec.sample_rate))
        edge = int(round(EDGE_S * rec.sample_rate))
        starts = [s for s in np.flatnonzero(on[1:] & ~on[:-1]) + 1 if s >= pre and np.all(~on[s - pre:s])]
        lengths = [int(np.argmin(on[s:])) if not np.all(on[s:]) else on.size - s for s in starts]
        if not starts or min(lengths) < int(0.05 * rec.sample_rate) + edge:
            raise ConfigError("needs switch-on stretches of 70 ms or more after 50 ms off", source=rec.source,
                              field="level")
        m = min(lengths)
        prof = np.mean([d[s - pre:s + m] for s in starts], axis=0)  # (pre + m,)
        t = (np.arange(pre + m) - pre) / rec.sample_rate
        fit_sl = slice(edge, pre + m - edge)

        def model(_x, a, tau, c, t=t, sos=sos, sl=fit_sl):
            return sosfiltfilt(sos, _step_decay(t, a, tau, c))[sl]

        a0 = max(float(np.max(prof) - prof[-1]), 1e-9)
        try:
            (a, tau, c), _ = curve_fit(model, t[fit_sl], prof[fit_sl], p0=(a0, max(t[-1] / 5, 2e-3), float(prof[-1])),
                                       bounds=([0.0, 1e-3, -np.inf], [np.inf, 100.0, np.inf]), maxfev=20000)
        except RuntimeError:
            raise ConfigError("no exponential decay found after switch-on", source=rec.source, field="lateral_force") \
                from None
        if not a > MIN_DECAY * (a + abs(c)):  # a DC drive's increase decays (nearly) to 0
            raise ConfigError("the friction increase does not decay after switch-on (a polarity carrier?)",
                              source=rec.source, field="lateral_force")
        taus.append(float(tau))
        if first is None:
            first = (t, prof, _step_decay(t, a, tau, c))
    if not taus:
        raise ConfigError("no DC recordings given", field="leakage")
    return LeakageFit(float(np.mean(taus)), np.array(taus), *first)
