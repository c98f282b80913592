"""Synthetic tribometer recordings with a known device, for testing and demonstrating calibration.

The simulated rig (after Kim et al. 2017 Sec. 2.1: 470 g counterweight, 10 kHz sampling, 20 s
per level) drags a pen over the panel; its load wobbles slowly (+-5 % at 0.37 Hz, a design
choice), the drive is switched on and off every ``switch_period`` s. Lateral force::

    f = mu fn + on * (df(level) + A(level)/2 sin(2 pi f_vib t)) + noise

with ``df`` the static friction increase (voltage input: ``mu k V^2``; intensity input: the
quadratic ``static`` coefficients) and ``A`` the peak-to-peak vibration amplitude (quadratic
``amplitude`` coefficients; for a voltage input ``amplitude_ratio * df``). Gaussian white noise
of ``noise`` N (standard deviation) is added to both force channels.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from surfhap.errors import ConfigError
from surfhap.exchange.tribometer import TribometerRecording

__all__ = ["synthetic_tribometer"]

COUNTERWEIGHT_LOAD = 0.470 * 9.81  # N, Kim et al. 2017 Sec. 2.1 (about 470 g)


def synthetic_tribometer(level: float, input: str = "intensity", *, mu_panel: float = 0.5, k: float | None = None,
                         static: Sequence[float] = (0.0, 0.0, 0.2), amplitude: Sequence[float] = (0.0, 0.0, 0.25),
                         amplitude_ratio: float = 0.5, normal_force: float = COUNTERWEIGHT_LOAD,
                         sample_rate: float = 10_000.0, duration: float = 20.0, switch_period: float = 1.0,
                         vibration_frequency: float = 150.0, noise: float = 0.005,
                         leakage_time_constant: float | None = None,
                         seed: int | np.random.Generator = 0) -> TribometerRecording:
    """One recording at ``level`` (intensity in (0, 1] or V); see the module docstring.

    ``leakage_time_constant`` (s, voltage input only): a DC drive whose charge leaks as in
    :mod:`surfhap.models.panel`: the effective voltage is the drive high-passed with this time
    constant, the friction increase ``mu k V_eff^2``, and there is no vibration."""
    if input not in ("intensity", "voltage"):
        raise ConfigError("must be intensity or voltage", field="input")
    if input == "voltage" and not (k is not None and k > 0):
        raise ConfigError("a voltage input needs k > 0 N/V^2", field="k")
    rng = np.random.default_rng(seed)
    n = int(round(duration * sample_rate))
    t = np.arange(n) / sample_rate
    on = (np.floor(t / switch_period) % 2 == 1)
    fn = normal_force * (1.0 + 0.05 * np.sin(2 * np.pi * 0.37 * t)) + rng.normal(0.0, noise, n)
    gate, source = on, f"synthetic-{input}-{level:g}"
    if input == "voltage":
        df = mu_panel * k * level ** 2
        pp = amplitude_ratio * df
        if leakage_time_constant is not None:
            from scipy.signal import lfilter

            a = leakage_time_constant / (leakage_time_constant + 1.0 / sample_rate)
            v = np.where(on, level, 0.0)
            v_eff = lfilter([a, -a], [1.0, -a], v)  # v_eff[n] = a (v_eff[n-1] + v[n] - v[n-1])
            df = mu_panel * k * v_eff ** 2  # the leaking charge acts on and off; a steady DC drive: no vibration
            gate, pp, source = 1.0, 0.0, f"synthetic-dc-{level:g}"
    else:
        df = static[0] + static[1] * level + static[2] * level ** 2
        pp = amplitude[0] + amplitude[1] * level + amplitude[2] * level ** 2
    vib = 0.5 * pp * np.sin(2 * np.pi * vibration_frequency * t)
    f = mu_panel * fn + gate * (df + vib) + rng.normal(0.0, noise, n)
    return TribometerRecording.from_arrays(input=input, lateral_force=f, normal_force=fn,
                                           level=np.where(on, level, 0.0), sample_rate=sample_rate, source=source)
