"""Haptic grains: the waveforms a shape is played with (Kim et al. 2017, Sec. 2, 3.1.2, 4.3).

Kim et al.'s Senseg Feelscreen plays fixed "haptic grains" whose only control is a
normalized intensity 0..1; the study used a smooth grain (EDGE-SOFT), a rough one
(AREA-GRAINY), an even area grain for shapes (AREA-EVEN) and a short, distinct one for
edges (EDGE-TICK) (Fig. 4). Their waveforms are proprietary, so surfhap has its own small,
documented grain set with those characters. A grain is a force envelope g(t) in [0, 1] at the
drive rate; its force is ``F(I) g(t)``, where ``F(I)`` is the device's intensity -> force
curve. The drive law then asks the display for that added friction.

============ ============ ==================================================================
grain        character    envelope g(t) (design choices, not from the paper)
============ ============ ==================================================================
area-even    smooth       1: the friction follows the intensity, nothing else
area-grainy  rough        raised-cosine grains of 4 ms at random times, 100 per second on
                          average (seeded), summed and clipped to 1
edge-tick    short tick   one raised-cosine pulse of 10 ms per edge crossing
============ ============ ==================================================================

``edge-soft`` is accepted as another name for the smooth grain (the paper calls EDGE-SOFT
"smooth", Sec. 3.1.2). While a tick plays it replaces the area grain (one grain at a time,
as on the Feelscreen).

Device curve: the paper measured a quadratic relation between grain intensity and friction
force (Fig. 2c, 3c). :meth:`DeviceCurve.fit` fits ``F = a I^2 + b I + c`` to tribometer data;
:meth:`DeviceCurve.kim2017` passes through the three points the paper quotes for EDGE-SOFT
(Sec. 3.1.2): about 0.075 N at the lowest measured intensity 0.1, the median 0.16 N at 0.7,
0.25 N at 1.0. On the simulated display the default is :meth:`DeviceCurve.square_law` with the
display's largest force (intensity 1 = the safety limit's voltage), so nothing saturates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from surfhap.errors import ConfigError
from surfhap.signal.tribometer import TRIBOMETER_BAND, TRIBOMETER_LARGEST, fit_quadratic, tribometer_amplitude  # noqa: F401 (re-exported)

__all__ = ["GrainParams", "GRAINS", "AREA_GRAINS", "DeviceCurve", "GrainPlayer", "grain_name", "hann_pulse", "tribometer_amplitude"]

GRAINS = ("area-even", "area-grainy", "edge-tick")
AREA_GRAINS = ("area-even", "area-grainy")
_ALIASES = {"edge-soft": "area-even", "smooth": "area-even", "grainy": "area-grainy", "rough": "area-grainy",
            "tick": "edge-tick"}

GRAINY_RATE = 100.0  # grains per second (design choice)
GRAINY_WIDTH = 0.004  # s (design choice)
TICK_WIDTH = 0.010  # s (design choice)


@dataclass(frozen=True)
class GrainParams:
    """Parameters of the grain waveforms (design choices, see the module docstring).

    grainy_rate  : grains per second of area-grainy (mean of a Poisson process).
    grainy_width : s, duration of one raised-cosine grain of area-grainy.
    tick_width   : s, duration of the edge tick's raised-cosine pulse.
    """

    grainy_rate: float = GRAINY_RATE
    grainy_width: float = GRAINY_WIDTH
    tick_width: float = TICK_WIDTH

    def __post_init__(self):
        if not (np.isfinite(self.grainy_rate) and 0 < self.grainy_rate <= 2000):
            raise ConfigError("must be in (0, 2000] per second", field="grainy_rate")
        for name in ("grainy_width", "tick_width"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0005 <= v <= 0.5):
                raise ConfigError("must be within 0.5 ms and 0.5 s", field=name)


def grain_name(name: str) -> str:
    """Canonical grain name (aliases resolved); ConfigError if unknown."""
    key = str(name).lower()
    key = _ALIASES.get(key, key)
    if key not in GRAINS:
        raise ConfigError(f"unknown grain {name!r} (choose from {', '.join(GRAINS)}; aliases {', '.join(_ALIASES)})",
                          field="grain")
    return key


def hann_pulse(width: float, rate: float) -> np.ndarray:
    """(k,) raised-cosine pulse of ``width`` s at ``rate`` Hz, peak 1, zero at both ends."""
    k = max(int(round(width * rate)), 3)
    return 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(1, k + 1) / (k + 1))


@dataclass(frozen=True)
class DeviceCurve:
    """Grain force (N) versus intensity: ``F(I) = a I^2 + b I + c``.

    :meth:`kim2017` is the curve the paper quotes for the Feelscreen; :meth:`square_law` is a
    display whose voltage is proportional to the intensity (the paper's assumption of a
    constant amplifier gain, Sec. 2.2), so that ``F = F_max I^2``.
    """

    a: float
    b: float = 0.0
    c: float = 0.0
    source: str = ""

    def __post_init__(self):
        if not all(np.isfinite(v) for v in (self.a, self.b, self.c)):
            raise ConfigError("coefficients must be finite", field="device")
        i = np.linspace(0.0, 1.0, 101)
        f = self.force(i, clip=False)
        if np.any(f < -1e-12) or np.any(np.diff(f) < -1e-12):
            raise ConfigError("the intensity -> force curve must be >= 0 and non-decreasing on [0, 1]", field="device")

    @classmethod
    def kim2017(cls) -> "DeviceCurve":
        """The quadratic through the points Kim et al. quote for EDGE-SOFT (Sec. 3.1.2, Fig. 2c):
        0.075 N at intensity 0.1 (the lowest measured), 0.16 N at 0.7, 0.25 N at 1.0."""
        return cls(0.17592593, 0.00092593, 0.07314815,
                   source="Kim et al. 2017 Sec. 3.1.2 / Fig. 2c (EDGE-SOFT): 0.075 N @ 0.1, 0.16 N @ 0.7, 0.25 N @ 1.0")

    @classmethod
    def square_law(cls, max_force: float) -> "DeviceCurve":
        """``F = max_force I^2``: voltage proportional to intensity, force to voltage squared."""
        if not (np.isfinite(max_force) and max_force > 0):
            raise ConfigError("must be > 0 N", field="max_force")
        return cls(float(max_force), 0.0, 0.0, source=f"square law, {max_force:.4g} N at intensity 1")

    def force(self, intensity: np.ndarray, clip: bool = True) -> np.ndarray:
        """F (N) at intensity (n,) in [0, 1] (clipped to that range when ``clip``)."""
        i = np.asarray(intensity, dtype=float)
        if clip:
            i = np.clip(i, 0.0, 1.0)
        return (self.a * i + self.b) * i + self.c

    @classmethod
    def fit(cls, intensity: np.ndarray, force: np.ndarray, source: str = "fit") -> "DeviceCurve":
        """Least-squares quadratic through (intensity (n,), force (n,) N) pairs, n >= 3."""
        i = np.asarray(intensity, dtype=float)
        f = np.asarray(force, dtype=float)
        if i.shape != f.shape or i.ndim != 1 or i.size < 3:
            raise ConfigError("need at least three (intensity, force) pairs", field="device")
        c, b, a = fit_quadratic(i, f).coefficients
        return cls(a, b, c, source=source)

    @classmethod
    def from_tribometer(cls, recordings: dict, fs: float, source: str = "tribometer") -> "DeviceCurve":
        """Fit from tribometer recordings ``{intensity: force (n,) N}`` at ``fs`` Hz: each
        recording's :func:`tribometer_amplitude`, then the quadratic fit (Sec. 2.2, Fig. 2c)."""
        if len(recordings) < 3:
            raise ConfigError("need recordings at three intensities or more", field="device")
        inten = np.array(sorted(float(k) for k in recordings))
        amp = np.array([tribometer_amplitude(recordings[k], fs) for k in sorted(recordings, key=float)])
        return cls.fit(inten, amp, source=source)

    def plot(self, fig=None):
        from surfhap.report.shape_figures import plot_device_curve

        return plot_device_curve(self, fig=fig)


class GrainPlayer:
    """Stateful grain synthesiser at the drive rate.

    ``process(intensity, tick) -> force``: intensity (m,) float area-grain intensity held at
    the drive rate (0 = nothing to play, e.g. finger lifted), tick (m,) float edge-tick
    intensity Ie at the drive sample where a tick starts (0 elsewhere). Returns (m,) float N,
    the friction the display should add (>= 0).
    """

    def __init__(self, grain: str, drive_rate: float, device: DeviceCurve, seed: int = 0,
                 params: GrainParams | None = None):
        self.grain = grain_name(grain)
        if self.grain not in AREA_GRAINS:
            raise ConfigError(f"{self.grain} is not an area grain ({', '.join(AREA_GRAINS)})", field="grain")
        if not (np.isfinite(drive_rate) and drive_rate >= 1000):
            raise ConfigError("drive rate must be >= 1000 Hz", field="drive_rate")
        self.drive_rate = float(drive_rate)
        self.device = device
        self.seed = int(seed)
        self.params = params or GrainParams()
        self._grain_pulse = hann_pulse(self.params.grainy_width, self.drive_rate)
        self._tick_pulse = hann_pulse(self.params.tick_width, self.drive_rate)
        self._p_event = self.params.grainy_rate / self.drive_rate
        self.reset()

    def reset(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self._grain_tail = np.zeros(self._grain_pulse.size - 1)
        self._tick_left = 0  # samples of the current tick still to play
        self._tick_amp = 0.0

    def _area_envelope(self, m: int) -> np.ndarray:
        if self.grain == "area-even":
            return np.ones(m)
        events = (self._rng.random(m) < self._p_event).astype(float)
        full = np.convolve(events, self._grain_pulse)  # (m + k - 1,)
        k = self._grain_tail.size
        full[:k] += self._grain_tail
        self._grain_tail = full[m:m + k].copy()
        return np.minimum(full[:m], 1.0)

    def process(self, intensity: np.ndarray, tick: np.ndarray) -> np.ndarray:
        inten = np.ascontiguousarray(intensity, dtype=np.float64)
        tick = np.ascontiguousarray(tick, dtype=np.float64)
        m = inten.shape[0]
        if tick.shape != (m,):
            raise ValueError("intensity and tick must be (m,) arrays of one length")
        even = self.grain == "area-even"
        env = inten if even else self._area_envelope(m)  # not read when even
        out = np.empty(m)
        d = self.device
        self._tick_left, self._tick_amp = _grain_kernel(inten, tick, env, even, float(d.a), float(d.b), float(d.c),
                                                        self._tick_pulse, int(self._tick_left), float(self._tick_amp), out)
        return out


@numba.njit(cache=True, nogil=True)
def _device_force(i, a, b, c):
    i = min(max(i, 0.0), 1.0)
    return (a * i + b) * i + c


@numba.njit(cache=True, nogil=True)
def _grain_kernel(inten, tick, env, even, a, b, c, pulse, tick_left, tick_amp, out):
    # area grain: device force of the held intensity (times the grainy envelope), 0 where silent
    m = inten.shape[0]
    for i in range(m):
        v = inten[i]
        if v > 0.0 and np.isfinite(v):
            f = _device_force(v, a, b, c)
            out[i] = f if even else f * env[i]
        else:
            out[i] = 0.0
    # ticks: continue the running one, then start new ones (a new tick restarts the pulse)
    kp = pulse.shape[0]
    first = -1
    for i in range(m):
        if tick[i] > 0.0 and np.isfinite(tick[i]):
            first = i
            break
    if tick_left > 0:
        end = m if first < 0 else first
        n = min(tick_left, end)
        off = kp - tick_left
        for q in range(n):
            out[q] = tick_amp * pulse[off + q]
        tick_left -= n
    s = first
    while s >= 0:
        amp = _device_force(tick[s], a, b, c)
        nxt = m
        for i in range(s + 1, m):
            if tick[i] > 0.0 and np.isfinite(tick[i]):
                nxt = i
                break
        n = min(kp, nxt - s)
        for q in range(n):
            out[s + q] = amp * pulse[q]
        tick_amp = amp
        tick_left = kp - n if nxt == m else 0
        s = nxt if nxt < m else -1
    return tick_left, tick_amp
