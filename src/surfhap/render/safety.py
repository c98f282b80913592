"""The safety stages: :class:`SafetyStage` ends every renderer; :class:`OutputSafety` is the
last pass of a live output, after gain and stop ramp, right before the backend.

The limits of :class:`SafetyStage` hold for *any* input sequence (property-tested with hypothesis):

* ``|y| <= v_max`` (default 250 V, Otake et al. 2022 Sec. IV-D) for every sample;
* the magnitude may rise by at most ``rise_rate / drive_rate`` volts per sample (an onset
  from zero to ``v_max`` takes at least ``v_max / rise_rate`` seconds); falling is never
  limited, because removing voltage is always safe;
* a NaN or infinite drive, load or touch age, a drive beyond ``absurd_factor * v_max``, a
  negative or absurd load, or a touch time stamp from the future (age below
  ``-clock_tolerance``), all give 0 V at once (a *fault*);
* a lifted finger (load below ``lift_threshold``) gives 0 V at once;
* watchdog: when the freshest touch sample is older than ``watchdog_timeout`` (50 ms), the
  magnitude ramps linearly to zero within ``watchdog_ramp`` (5 ms) and stays there until a
  fresh touch sample arrives.

Polarity is free: a polarity carrier flips the sign without changing the magnitude.
Both passes run the one compiled kernel (``_safety_kernel``: each limit written once), which
allocates nothing and keeps its state in a small array.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import numba
import numpy as np
from pydantic import Field, model_validator

from surfhap.checked import checked_dataclass

__all__ = ["SafetyLimits", "SafetyStage", "stage_block", "SafetyCounters", "OutputSafety"]

_Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]


@checked_dataclass
class SafetyLimits:
    """Limits of the safety stage (SI units; all finite, > 0 unless stated).

    v_max            : V, largest drive magnitude ever output.
    rise_rate        : V/s, largest rise of the drive magnitude (default: 0 to v_max in 0.1 ms).
    lift_threshold   : N (>= 0, below max_load), loads below this mean "finger lifted" -> 0 V.
    max_load         : N, loads above this are absurd (sensor fault) -> 0 V.
    absurd_factor    : (>= 1) drive inputs beyond absurd_factor * v_max are treated as faults.
    watchdog_timeout : s, touch-sample age after which the output ramps to zero.
    watchdog_ramp    : s, longest time the ramp to zero may take.
    clock_tolerance  : s, touch ages down to -clock_tolerance count as fresh (rounding).
    """

    v_max: _Positive = 250.0
    rise_rate: _Positive = 2.5e6
    lift_threshold: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.02
    max_load: _Positive = 50.0
    absurd_factor: Annotated[float, Field(ge=1, allow_inf_nan=False)] = 4.0
    watchdog_timeout: _Positive = 0.050
    watchdog_ramp: _Positive = 0.005
    clock_tolerance: _Positive = 1.0e-3

    @model_validator(mode="after")
    def _lift_below_max_load(self):
        if self.lift_threshold >= self.max_load:
            raise ValueError("lift_threshold must be below max_load")
        return self

    def kernel_args(self, drive_rate: float, hard_age: bool) -> tuple:
        """The limits as the safety kernel applies them at ``drive_rate`` Hz (> 0): v_max V,
        rise and watchdog-ramp steps V per sample, lift and max load N, absurd drive V, the
        watchdog timeout s, the touch age (s) beyond which the output is 0 V at once
        (``hard_age``: timeout + ramp, the output pass; else never, a renderer's stage) and
        the clock tolerance s."""
        fs = float(drive_rate)
        if not (np.isfinite(fs) and fs > 0):
            raise ValueError("drive_rate must be positive")
        return (self.v_max, self.rise_rate / fs, self.v_max / (self.watchdog_ramp * fs), self.lift_threshold, self.max_load,
                self.absurd_factor * self.v_max, self.watchdog_timeout,
                self.watchdog_timeout + self.watchdog_ramp if hard_age else np.inf, self.clock_tolerance)


@dataclass(frozen=True)
class SafetyCounters:
    """Sample counts since the last reset, of a :class:`SafetyStage` or of the
    :class:`OutputSafety` pass (the kernel's counters; ``lifted`` is 0 on the output pass, which
    has no load, and ``halted`` is 0 on a renderer's stage)."""

    samples: int
    clamped: int
    rise_limited: int
    faults: int
    lifted: int
    watchdog: int
    halted: int


_FLOAT_MAX = float(np.finfo(np.float64).max)
_CHUNK = 256  # samples the renderer's stage checks at once for the common case (see _passes_through)


@numba.njit(cache=True, nogil=True)
def _passes_through(x, load, touch_age, prev, scale, v_max, rise_step, lift, max_load, absurd, timeout, tolerance):
    # the clamped count of the samples of a renderer's stage (finite scale, no ramp, no halt) when
    # every one is in the common case: finger on (lift <= load <= max_load), fresh touch data
    # (-tolerance <= age <= timeout), a sane drive (|v| <= absurd) whose magnitude min(|v| scale,
    # v_max) does not rise above the previous one + rise_step. Then _safety_kernel's loop emits
    # exactly +-that magnitude for each (prev stays the previous magnitude), so the pass can be
    # vectorised; else -1 (the loop runs). No branch: NaN fails every comparison.
    ok = True
    clamped = 0
    last = prev
    for i in range(x.shape[0]):
        ld = load[i]
        age = touch_age[i]
        a = abs(x[i])
        m = a * scale
        mag = v_max if m > v_max else m
        ok &= ((ld >= lift) & (ld <= max_load) & (age >= -tolerance) & (age <= timeout) & (a <= absurd)
               & (mag <= last + rise_step))
        clamped += m > v_max
        last = mag
    return clamped if ok else -1


# The one safety kernel, of a renderer's stage and of the output pass.
# state (float64): 0 previous emitted magnitude, 1 stop-ramp position (1 = full, 0 = stopped)
# counters (int64): samples, clamped, rise_limited, faults, lifted, watchdog, halted
# load, touch_age: (n,) per sample (a renderer's stage), or empty (the output pass: no load,
# the touch age of sample i is age0 + i dt)
@numba.njit(cache=True, nogil=True)
def _safety_kernel(x, load, touch_age, out, state, counters, gain, ramp_step, age0, dt, halt, v_max, rise_step,
                   wd_step, lift, max_load, absurd, timeout, hard_age, tolerance):
    # the counters and the state stay in locals through the loop (the stores to out may alias the
    # arrays: per-sample counter updates in memory would chain every sample)
    n = out.shape[0]
    absurd = min(absurd, _FLOAT_MAX)  # absurd_factor v_max may overflow: |v| <= absurd must mean finite
    finger = load.shape[0] > 0
    prev = state[0]
    ramp = state[1]
    clamped = rise_limited = faults = lifted = watchdog = halted = 0
    scale = gain * ramp
    scale_ok = np.isfinite(scale)
    common = finger and ramp_step == 0.0 and not halt and scale_ok  # a renderer's stage: chunks may pass through
    for i0 in range(0, n, _CHUNK):
        i1 = min(i0 + _CHUNK, n)
        c = _passes_through(x[i0:i1], load[i0:i1], touch_age[i0:i1], prev, scale, v_max, rise_step, lift, max_load, absurd,
                            timeout, tolerance) if common else -1
        if c >= 0:  # slices: indices from 0, no wraparound, the loop vectorises (unless out is x)
            clamped += c
            xs, o = x[i0:i1], out[i0:i1]
            for k in range(o.shape[0]):
                mag = min(abs(xs[k]) * scale, v_max)
                o[k] = mag if xs[k] >= 0.0 else -mag
            prev = abs(out[i1 - 1])
            continue
        for i in range(i0, i1):
            v = x[i]
            if ramp_step > 0.0:  # the stop ramp (output pass only): this sample's scale, then one step down
                scale = gain * ramp
                scale_ok = np.isfinite(scale)
                ramp -= ramp_step
                if ramp < 1e-9:  # rounding of the repeated subtraction: end exactly at 0
                    ramp = 0.0
            if halt:
                halted += 1
                prev = 0.0
                out[i] = 0.0
                continue
            if finger:
                ld = load[i]
                age = touch_age[i]
                # finite, 0 <= load <= max_load, -tolerance <= age < inf (NaN fails every comparison)
                good = (ld >= 0.0) & (ld <= max_load) & (age >= -tolerance) & (age < np.inf)
            else:
                ld = lift
                age = age0 + i * dt
                good = True
            good &= (abs(v) <= absurd) & scale_ok  # absurd is finite (above): so is v
            if not (good & (ld >= lift)):  # a fault, else a lifted finger: 0 V at once
                if good:
                    lifted += 1
                else:
                    faults += 1
                prev = 0.0
                out[i] = 0.0
                continue
            mag = abs(v) * scale
            if mag > v_max:
                mag = v_max
                clamped += 1
            if not age <= timeout:  # stale, no touch yet (inf) or NaN
                watchdog += 1
                cap = prev - wd_step
                if cap < 0.0 or not age <= hard_age:
                    cap = 0.0
                if mag > cap:
                    mag = cap
            elif mag > prev + rise_step:
                mag = prev + rise_step
                rise_limited += 1
            prev = mag
            out[i] = mag if v >= 0.0 else -mag
    state[0] = prev
    state[1] = ramp
    counters[0] += n
    counters[1] += clamped
    counters[2] += rise_limited
    counters[3] += faults
    counters[4] += lifted
    counters[5] += watchdog
    counters[6] += halted


@numba.njit(cache=True, nogil=True)
def stage_block(drive, load, touch_age, out, state, counters, limits):
    """A renderer's safety stage over (n,) drive V, load N, touch age s into ``out``: state,
    counters and limits of :meth:`SafetyStage.kernel_args` (compiled callers)."""
    _safety_kernel(drive, load, touch_age, out, state, counters, 1.0, 0.0, 0.0, 0.0, False, *limits)


class SafetyStage:
    """Stateful safety processor at the drive rate.

    ``process(drive, load, touch_age)`` takes three (n,) float arrays: the drive in volts,
    the finger load in newtons, and the age in seconds of the freshest touch sample at each
    drive sample. It returns (n,) float volts that satisfy :class:`SafetyLimits`.
    """

    def __init__(self, drive_rate: float, limits: SafetyLimits | None = None):
        self.limits = limits or SafetyLimits()
        self._args = self.limits.kernel_args(drive_rate, hard_age=False)
        self.drive_rate = float(drive_rate)
        self._state = np.array([0.0, 1.0])
        self._counters = np.zeros(7, dtype=np.int64)

    def reset(self) -> None:
        """Forget the previous output (next onset starts from 0 V) and zero the counters."""
        self._state[0] = 0.0
        self._counters[:] = 0

    def process(self, drive: np.ndarray, load: np.ndarray, touch_age: np.ndarray) -> np.ndarray:
        drive, load, touch_age = (np.ascontiguousarray(a, dtype=np.float64) for a in (drive, load, touch_age))
        if not (drive.shape == load.shape == touch_age.shape) or drive.ndim != 1:
            raise ValueError("drive, load and touch_age must be 1-D arrays of one length")
        stage_block(drive, load, touch_age, out := np.empty_like(drive), *self.kernel_args())
        return out

    def kernel_args(self) -> tuple:
        """(state, counters, limits): this stage for :func:`stage_block`."""
        return self._state, self._counters, self._args

    @property
    def counters(self) -> SafetyCounters:
        return SafetyCounters(*self._counters.tolist())


class OutputSafety:
    """The final safety pass of a live output: what the backend receives, sample by sample.

    Everything that touches the signal after a renderer's own :class:`SafetyStage` (gain,
    stop ramp, silencing of queued drive on lift, a renderer switch, an engine halt) is
    folded into this one pass, so its limits hold on the emitted stream whatever happened
    upstream. It knows the last emitted magnitude across blocks and enforces, per sample:

    * gain (0-1) and the stop ramp (linear, ``ramp_seconds`` from full to zero) applied
      first, so they can never make the output rise faster than allowed;
    * ``|y| <= v_max``; magnitude rise at most ``rise_rate / drive_rate`` per sample;
    * a non-finite or absurd sample (beyond ``absurd_factor * v_max``) gives 0 V;
    * watchdog on the emission time: when the freshest touch sample is older than
      ``watchdog_timeout`` the magnitude ramps to zero (``watchdog_ramp``), and it is 0 V
      for every sample older than ``watchdog_timeout + watchdog_ramp``;
    * ``halt``: 0 V (a failed backend or a stopped engine).

    ``process(x, out, age0, gain, halt)`` works in place when ``x is out``; it allocates
    nothing and never raises for any float input.
    """

    def __init__(self, drive_rate: float, limits: SafetyLimits | None = None, ramp_seconds: float = 0.010):
        if not (np.isfinite(ramp_seconds) and ramp_seconds > 0):
            raise ValueError("ramp_seconds must be positive")
        self.drive_rate = float(drive_rate)
        self.ramp_seconds = float(ramp_seconds)
        self._state = np.zeros(2)
        self._counters = np.zeros(7, dtype=np.int64)
        self._no_finger = np.zeros(0)  # the output pass has no per-sample load: its touch age is age0 + i dt
        self.set_limits(limits or SafetyLimits())
        self.reset()

    def set_limits(self, limits: SafetyLimits) -> None:
        """Take new limits (e.g. those of a renderer switched in); the state is kept."""
        self.limits = limits
        self._args = limits.kernel_args(self.drive_rate, hard_age=True)
        self._dt = 1.0 / self.drive_rate

    def reset(self) -> None:
        """Silence remembered, stop ramp back to full, counters zeroed."""
        self._state[0] = 0.0
        self._state[1] = 1.0
        self._counters[:] = 0
        self._ramp_step = 0.0

    def start_ramp(self) -> None:
        """Begin the ramp to zero (stop); it takes ``ramp_seconds``."""
        if self._ramp_step == 0.0:
            self._ramp_step = 1.0 / max(1.0, self.ramp_seconds * self.drive_rate)

    @property
    def ramped_down(self) -> bool:
        """True once the stop ramp has reached zero."""
        return self._ramp_step > 0.0 and self._state[1] <= 0.0

    def process(self, x: np.ndarray, out: np.ndarray, age0: float, gain: float = 1.0, halt: bool = False) -> np.ndarray:
        """``x``, ``out``: (n,) float64 volts (may be the same array); ``age0``: s, age of the
        freshest touch sample at the first sample (``inf`` if none); ``gain`` in [0, 1]."""
        g = float(gain)
        if not 0.0 <= g <= 1.0:  # also catches NaN
            g = 0.0
        _safety_kernel(x, self._no_finger, self._no_finger, out, self._state, self._counters, g, self._ramp_step,
                       float(age0), self._dt, bool(halt), *self._args)
        return out

    def silence(self) -> None:
        """After a block was replaced by zeros outside the kernel: remember 0 V."""
        self._state[0] = 0.0

    @property
    def counters(self) -> SafetyCounters:
        return SafetyCounters(*self._counters.tolist())
