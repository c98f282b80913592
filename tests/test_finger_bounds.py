"""One set of finger bounds (issue 20): a touch stream is plausible for the trajectory check
exactly when the force-feedback engine takes it, at the bounds of models/finger.py."""

from __future__ import annotations

import numpy as np
import pytest

from surfhap.ff import FALCON, FFEngine, Stiffness
from surfhap.render.kinematics import TouchPredictor
from surfhap.models import finger
from surfhap.models.trajectory import implausible

RATE = 60.0  # Hz, touch samples (the paper's tablet)


def _stream(speed: float, load: float):
    t = np.arange(0.0, 0.1, 1.0 / RATE)  # short: even at 1.5 x MAX_SPEED the finger stays on a tablet
    return t, 0.05 + speed * t, np.full(t.size, 0.07), np.full(t.size, load)


def _engine_rejects(t, x, y, load) -> int:
    eng = FFEngine([Stiffness(300.0)], FALCON, TouchPredictor(), rate=1000.0)
    for k in range(t.size):
        eng.touch(float(t[k]), float(x[k] - 0.05), float(y[k] - 0.07), float(load[k]))
        eng.tick(float(t[k]), 0.0, 0.0, 0.0, float(t[k]))
    return eng.touch_rejected


@pytest.mark.parametrize("scale,plausible", [(0.8, True), (1.5, False)])
def test_speed_bound_is_the_same_for_files_and_the_live_engine(scale, plausible):
    t, x, y, load = _stream(scale * finger.MAX_SPEED, 1.0)
    assert (implausible(t, x, y, load) is None) == plausible
    assert (_engine_rejects(t, x, y, load) == 0) == plausible


@pytest.mark.parametrize("scale,plausible", [(0.8, True), (1.5, False)])
def test_load_bound_is_the_same_for_files_and_the_live_engine(scale, plausible):
    t, x, y, load = _stream(0.05, scale * finger.MAX_LOAD)
    bad = implausible(t, x, y, load)
    assert (bad is None) == plausible
    assert (_engine_rejects(t, x, y, load) == 0) == plausible


def test_bounds_are_ones_a_finger_reaches_and_a_unit_slip_exceeds():
    """Independent figures: a fast flick reaches ~2 m/s and a hard press ~40 N (both plausible);
    a 20 mm/s scan written in mm/s (20) or a 1 N press in grams (100) is not."""
    assert 2.0 <= finger.MAX_SPEED < 20.0
    assert 40.0 <= finger.MAX_LOAD < 100.0
