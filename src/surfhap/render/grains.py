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
force (Fig. 2c, 3c): :class:`surfhap.models.device_curve.DeviceCurve` (``F = c0 + c1 I + c2 I^2``,
with :meth:`~surfhap.models.device_curve.DeviceCurve.kim2017` through the three points the paper
quotes for EDGE-SOFT). The shape renderer's default is the square law of the display's model,
``F = mu_panel k (I v_max)^2`` (intensity 1 = the safety limit's voltage), so nothing saturates.
"""

from __future__ import annotations

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from surfhap.errors import ConfigError
from surfhap.models.device_curve import DeviceCurve

__all__ = ["GrainParams", "GRAINS", "AREA_GRAINS", "GrainPlayer", "grain_block", "grain_name", "hann_pulse"]

GRAINS = ("area-even", "area-grainy", "edge-tick")
AREA_GRAINS = ("area-even", "area-grainy")
_ALIASES = {"edge-soft": "area-even", "smooth": "area-even", "grainy": "area-grainy", "rough": "area-grainy",
            "tick": "edge-tick"}

GRAINY_RATE = 100.0  # grains per second (design choice)
GRAINY_WIDTH = 0.004  # s (design choice)
TICK_WIDTH = 0.010  # s (design choice)


class GrainParams(BaseModel):
    """Parameters of the grain waveforms (design choices, see the module docstring).

    grainy_rate  : grains per second of area-grainy (mean of a Poisson process), (0, 2000].
    grainy_width : s, duration of one raised-cosine grain of area-grainy, 0.5 ms to 0.5 s.
    tick_width   : s, duration of the edge tick's raised-cosine pulse, 0.5 ms to 0.5 s.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    grainy_rate: float = Field(GRAINY_RATE, gt=0, le=2000)
    grainy_width: float = Field(GRAINY_WIDTH, ge=0.0005, le=0.5)
    tick_width: float = Field(TICK_WIDTH, ge=0.0005, le=0.5)


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
        if device.input != "intensity":
            raise ConfigError("a grain's device curve is over intensity", field="device")
        if not (np.isfinite(drive_rate) and drive_rate >= 1000):
            raise ConfigError("drive rate must be >= 1000 Hz", field="drive_rate")
        self.drive_rate = float(drive_rate)
        self.device = device
        self.seed = int(seed)
        self.params = params or GrainParams()
        self._grain_pulse = hann_pulse(self.params.grainy_width, self.drive_rate)
        self._tick_pulse = hann_pulse(self.params.tick_width, self.drive_rate)
        self._p_event = self.params.grainy_rate / self.drive_rate
        self._curve = np.array([*device.coefficients, device.u_max], dtype=np.float64)
        self.reset()

    def reset(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self._grain_tail = np.zeros(self._grain_pulse.size - 1)
        self._ticks = np.zeros(2)  # samples of the current tick still to play, its amplitude

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
        out = np.empty(m)
        grain_block(inten, tick, *self.kernel_args(inten), out)
        return out

    def kernel_args(self, intensity: np.ndarray) -> tuple:
        """The rest of :func:`grain_block`'s arguments for the next block of ``intensity`` (m,)
        (the area-grainy envelope is drawn here): envelope, even, curve, tick pulse and state."""
        even = self.grain == "area-even"
        env = intensity if even else self._area_envelope(intensity.shape[0])  # not read when even
        return env, even, self._curve, self._tick_pulse, self._ticks


@numba.njit(cache=True, nogil=True)
def _device_force(i, c0, c1, c2, top):
    # DeviceCurve.force for one intensity (ascending coefficients, clipped to [0, top])
    i = min(max(i, 0.0), top)
    return (c2 * i + c1) * i + c0


@numba.njit(cache=True, nogil=True)
def grain_block(inten, tick, env, even, curve, pulse, ticks, out):
    """The grains' force (m,) N into ``out``: area grain at the held intensity (times the grainy
    envelope ``env`` unless ``even``), edge ticks; ``curve`` (c0, c1, c2, top) the device curve,
    ``ticks`` the running tick (samples left, amplitude), updated (:meth:`GrainPlayer.kernel_args`)."""
    c0, c1, c2, top = curve[0], curve[1], curve[2], curve[3]
    tick_left, tick_amp = int(ticks[0]), ticks[1]
    # area grain: device force of the held intensity (times the grainy envelope), 0 where silent
    m = inten.shape[0]
    for i in range(m):
        v = inten[i]
        if v > 0.0 and np.isfinite(v):
            f = _device_force(v, c0, c1, c2, top)
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
        amp = _device_force(tick[s], c0, c1, c2, top)
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
    ticks[0], ticks[1] = tick_left, tick_amp
