"""A renderer's safety stage on long, mostly ordinary inputs (where the compiled kernel passes
whole chunks through at once) equals, exactly, the limits written out sample by sample in Python:
output and counters, for any block split, with rare faults, lifts, stale touch data and onsets
placed anywhere, including at chunk edges."""

import dataclasses
import math

import numpy as np
import pytest

from surfhap.render.safety import SafetyLimits, SafetyStage

FS = 20000.0


def _reference(lim, drive, load, age):
    rise, wd = lim.rise_rate / FS, lim.v_max / (lim.watchdog_ramp * FS)
    prev = 0.0
    out = np.zeros(drive.size)
    c = dict(samples=drive.size, clamped=0, rise_limited=0, faults=0, lifted=0, watchdog=0, halted=0)
    for i, (v, ld, a) in enumerate(zip(drive.tolist(), load.tolist(), age.tolist())):
        if (not (math.isfinite(v) and math.isfinite(ld) and math.isfinite(a)) or abs(v) > lim.absurd_factor * lim.v_max
                or ld < 0 or ld > lim.max_load or a < -lim.clock_tolerance):
            c["faults"] += 1
            prev = 0.0
            continue
        if ld < lim.lift_threshold:
            c["lifted"] += 1
            prev = 0.0
            continue
        mag = abs(v)
        if mag > lim.v_max:
            mag = lim.v_max
            c["clamped"] += 1
        if a > lim.watchdog_timeout:
            c["watchdog"] += 1
            mag = min(mag, max(prev - wd, 0.0))
        elif mag > prev + rise:
            mag = prev + rise
            c["rise_limited"] += 1
        prev = mag
        out[i] = mag if v >= 0 else -mag
    return out, c


@pytest.mark.parametrize("seed", range(6))
def test_long_blocks_equal_the_limits_written_out(seed):
    rng = np.random.default_rng(seed)
    n = 6000
    lim = SafetyLimits()
    drive = 300.0 * np.sin(np.arange(n) * 0.003) * np.where((np.arange(n) // 5) % 2, -1.0, 1.0)  # past v_max: clamped
    load = np.full(n, 0.5)
    age = (np.arange(n) % 160) / FS
    for _ in range(rng.integers(1, 12)):  # rare events at random places (often near 256-sample chunk edges)
        i = int(rng.choice([rng.integers(n), 256 * rng.integers(1, n // 256) + rng.integers(-2, 3)]))
        k = int(rng.integers(1, 40))
        kind = rng.integers(7)
        if kind == 0:
            drive[i:i + k] = rng.choice([np.nan, np.inf, -np.inf, 5000.0])
        elif kind == 1:
            load[i:i + k] = rng.choice([0.0, 0.01, -1.0, np.nan, 80.0])
        elif kind == 2:
            age[i:i + k] = rng.choice([0.06, 0.3, np.inf, -0.01, np.nan])
        elif kind == 3:
            drive[i:i + k] = 0.0  # a gap, then an onset the rise limit shapes
        elif kind == 4:
            drive[i:i + k] = -drive[i:i + k] * 3.0
        elif kind == 5:
            age[i:i + k] = lim.watchdog_timeout  # exactly at the timeout: still fresh
        else:
            load[i:i + k] = lim.max_load  # exactly at the bound: accepted
    want, counts = _reference(lim, drive, load, age)
    stage = SafetyStage(FS, lim)
    cuts = np.sort(rng.integers(0, n, rng.integers(0, 5)))
    got = np.concatenate([stage.process(d, ld, a) for d, ld, a in zip(np.split(drive, cuts), np.split(load, cuts), np.split(age, cuts))])
    np.testing.assert_array_equal(got, want)
    assert dataclasses.asdict(stage.counters) == counts


def test_non_finite_drive_is_a_fault_even_when_absurd_overflows():
    """absurd_factor * v_max may overflow to inf for a huge v_max: inf and NaN drives still give 0 V."""
    lim = SafetyLimits(v_max=1e308)
    n = 600
    drive = np.full(n, 1.0)
    drive[[3, 300, 301, 599]] = [np.inf, -np.inf, np.nan, np.inf]
    stage = SafetyStage(FS, lim)
    out = stage.process(drive, np.full(n, 0.5), np.zeros(n))
    assert np.all(np.isfinite(out)) and not np.any(out[[3, 300, 301, 599]])
    assert stage.counters.faults == 4
