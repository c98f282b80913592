"""The safety limits hold for any input sequence (hypothesis)."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from surfhap.render.safety import SafetyLimits, SafetyStage

FS = 20000.0
LIM = SafetyLimits()
RISE = LIM.rise_rate / FS
RAMP = LIM.v_max / (LIM.watchdog_ramp * FS)

anything = st.floats(allow_nan=True, allow_infinity=True, width=64)
volts = st.one_of(anything, st.floats(-2000, 2000))
loads = st.one_of(anything, st.floats(-1, 60), st.just(0.5))
ages = st.one_of(anything, st.floats(-0.01, 0.2), st.just(0.001))


def _check(drive, load, age, out):
    mag = np.abs(out)
    assert np.all(np.isfinite(out))
    assert np.all(mag <= LIM.v_max)
    prev = np.concatenate(([0.0], mag[:-1]))
    assert np.all(mag - prev <= RISE * (1 + 1e-12) + 1e-12)
    fault = ~(np.isfinite(drive) & np.isfinite(load) & np.isfinite(age)) | (np.abs(np.nan_to_num(drive)) > LIM.absurd_factor * LIM.v_max)
    fault |= (np.nan_to_num(load) < 0) | (np.nan_to_num(load) > LIM.max_load) | (np.nan_to_num(age) < -LIM.clock_tolerance)
    assert np.all(out[fault] == 0.0)
    lifted = np.nan_to_num(load, nan=1.0) < LIM.lift_threshold
    assert np.all(out[lifted] == 0.0)
    stale = np.nan_to_num(age) > LIM.watchdog_timeout
    assert np.all(mag[stale] <= np.maximum(prev[stale] - RAMP, 0.0) + 1e-9)
    # the sign never flips against the input
    assert np.all(out * np.nan_to_num(drive) >= 0)


@settings(max_examples=300, deadline=None)
@given(st.integers(1, 400).flatmap(lambda n: st.tuples(
    arrays(np.float64, n, elements=volts), arrays(np.float64, n, elements=loads), arrays(np.float64, n, elements=ages))))
def test_limits_hold_for_any_input(data):
    drive, load, age = data
    stage = SafetyStage(FS, LIM)
    out = stage.process(drive, load, age)
    _check(drive, load, age, out)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.integers(1, 60), min_size=1, max_size=8), st.floats(0, 2000), st.integers(0, 2**31 - 1))
def test_limits_hold_across_block_boundaries(blocks, amplitude, seed):
    rng = np.random.default_rng(seed)
    n = sum(blocks)
    drive = amplitude * rng.standard_normal(n)
    load = rng.choice([0.0, 0.01, 0.5, 2.0], n)
    age = rng.choice([0.0, 0.01, 0.06, 0.3], n)
    stage = SafetyStage(FS, LIM)
    outs, i = [], 0
    for b in blocks:
        outs.append(stage.process(drive[i:i + b], load[i:i + b], age[i:i + b]))
        i += b
    out = np.concatenate(outs)
    _check(drive, load, age, out)
    stage.reset()
    np.testing.assert_array_equal(stage.process(drive, load, age), out)


def test_watchdog_ramps_to_zero_within_5_ms():
    stage = SafetyStage(FS, LIM)
    n = int(0.2 * FS)
    t = np.arange(n) / FS
    drive = np.where(np.arange(n) % 10 < 5, 200.0, -200.0)  # 2 kHz carrier at 200 V
    last_touch = np.where(t < 0.1, t, 0.1)  # touch samples stop at 100 ms
    out = stage.process(drive, np.full(n, 0.5), t - last_touch)
    assert np.max(np.abs(out[(t > 0.02) & (t < 0.1)])) == 200.0
    trip = 0.1 + LIM.watchdog_timeout
    assert np.all(np.abs(out[t > trip + LIM.watchdog_ramp + 1 / FS]) == 0.0)
    assert np.abs(out[np.searchsorted(t, trip) - 1]) == 200.0
    assert stage.counters.watchdog > 0


def test_onset_is_rise_limited_and_polarity_free():
    stage = SafetyStage(FS, LIM)
    n = 200
    drive = np.where(np.arange(n) % 2 == 0, 250.0, -250.0)
    out = stage.process(drive, np.full(n, 0.5), np.zeros(n))
    steps = int(np.ceil(LIM.v_max / RISE))
    assert np.all(np.abs(out[steps:]) == 250.0)
    assert np.all(np.sign(out) == np.sign(drive))
    np.testing.assert_allclose(np.abs(out[: steps - 1]), RISE * np.arange(1, steps))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40).flatmap(lambda n: st.tuples(
    arrays(np.float64, n, elements=st.one_of(anything, st.floats(-5, 5))),
    arrays(np.float64, n, elements=loads),
    arrays(np.float64, n, elements=st.one_of(anything, st.floats(-1, 1))))),
    st.sampled_from(["otake2022", "otake2021", "friction-only", "square"]))
def test_whole_chain_output_within_limits_for_any_touch_input(data, method):
    """Arbitrary (even NaN / absurd) finger state through the full chain never exceeds the limits."""
    from surfhap import ChainConfig, TextureChain, load_material

    speed, load, touch_time = data
    chain = TextureChain(load_material("leather"), ChainConfig(method=method, alpha=5000.0))
    out = chain.process(speed, load, touch_time)
    mag = np.abs(out.drive)
    assert np.all(np.isfinite(out.drive))
    assert np.all(mag <= LIM.v_max)
    assert np.all(np.diff(np.concatenate(([0.0], mag))) <= RISE * (1 + 1e-12) + 1e-12)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 80), st.one_of(anything, st.floats(-0.1, 0.2)), st.one_of(anything, st.floats(-0.5, 1.5)),
                          st.booleans(), st.booleans()), min_size=1, max_size=8),
       st.integers(0, 2**31 - 1))
def test_output_pass_holds_the_limits_for_any_blocks_gain_and_ages(blocks, seed):
    """OutputSafety (the last pass of a live output): for any drive, gain, touch age, halt
    and stop, every sample is finite, within v_max, rise-limited across blocks, 0 V when the
    touch data is older than timeout + ramp or when halted, and 0 V after the stop ramp."""
    from surfhap.render.safety import OutputSafety

    rng = np.random.default_rng(seed)
    guard = OutputSafety(FS, LIM, ramp_seconds=0.002)
    outs, ages, silent = [], [], []
    stop_at = None
    n_total = 0
    for n, age0, gain, halt, stop in blocks:
        x = rng.choice([0.0, 100.0, -250.0, 600.0, 2000.0, np.nan, np.inf], n) * rng.uniform(0.5, 1.0, n)
        if stop:
            guard.start_ramp()
            stop_at = n_total if stop_at is None else stop_at
        y = guard.process(x.copy(), np.empty(n), age0, gain, halt)
        age = age0 + np.arange(n) / FS
        outs.append(y)
        ages.append(age)
        idx = n_total + np.arange(n)
        silent.append(np.full(n, halt) | ~(np.nan_to_num(age, nan=1.0) <= LIM.watchdog_timeout + LIM.watchdog_ramp)
                      | ((idx >= stop_at + np.ceil(0.002 * FS)) if stop_at is not None else False))
        n_total += n
    out = np.concatenate(outs)
    mag = np.abs(out)
    assert np.all(np.isfinite(out)) and np.all(mag <= LIM.v_max)
    assert np.all(np.diff(np.concatenate(([0.0], mag))) <= RISE * (1 + 1e-12) + 1e-12)
    assert not np.any(out[np.concatenate(silent)])


def test_output_pass_applies_gain_and_stop_ramp():
    from surfhap.render.safety import OutputSafety

    g = OutputSafety(FS, LIM, ramp_seconds=0.001)
    steady = g.process(np.full(400, 200.0), np.empty(400), 0.0, 0.5)
    assert steady[-1] == pytest.approx(100.0)  # gain inside the pass (after its rise)
    g.start_ramp()
    tail = g.process(np.full(40, 200.0), np.empty(40), 0.0, 0.5)
    np.testing.assert_allclose(tail[:20], 100.0 * (1 - np.arange(20) / 20), atol=1e-9)
    assert not np.any(tail[20:]) and g.ramped_down


def test_both_safety_passes_count_in_one_type():
    """A renderer's stage and the output pass report the same counters: a lifted finger counts
    every sample as lifted on the stage, a halt every sample as halted on the output pass."""
    from surfhap.render.safety import OutputSafety, SafetyCounters

    n = 50
    st = SafetyStage(FS, LIM)
    st.process(np.full(n, 100.0), np.zeros(n), np.zeros(n))
    g = OutputSafety(FS, LIM)
    g.process(np.full(n, 100.0), np.empty(n), 0.0, 1.0, halt=True)
    assert st.counters == SafetyCounters(samples=n, clamped=0, rise_limited=0, faults=0, lifted=n, watchdog=0, halted=0)
    assert g.counters == SafetyCounters(samples=n, clamped=0, rise_limited=0, faults=0, lifted=0, watchdog=0, halted=n)


@pytest.mark.parametrize("field, value", [("v_max", float("nan")), ("rise_rate", 0.0), ("watchdog_timeout", float("inf")),
                                          ("absurd_factor", 0.5), ("lift_threshold", -0.1), ("max_load", -1.0)])
def test_a_bad_limit_is_one_config_error_naming_its_field(field, value):
    from surfhap.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        SafetyLimits(**{field: value})
    assert err.value.field == field
    with pytest.raises(ConfigError, match="lift_threshold"):
        SafetyLimits(lift_threshold=2.0, max_load=1.0)
