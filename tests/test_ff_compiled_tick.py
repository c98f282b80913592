"""The force-feedback tick is one compiled call (issue 20, ``ff_effects_tick``): no Python
effect, field or merge code runs on a tick of built-in effects; the compiled laws of every
effect and field are checked against independent references (scipy's bilinear interpolation,
the laws of 004 Sec. 3 written out here in numpy); Python effects still merge in their place."""

import math
import os
import sys

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from surfhap.ff import FALCON, Attraction, Effect, FFEngine, GridField, RectsField, Roughness, Shape, Sliding, Stiffness
from surfhap.ff.effects import TickState
from surfhap.ff.fields import Ramp
from surfhap.render.kinematics import TouchPredictor

KM = FALCON.k_max
W, H = 0.197, 0.148
POINTS = [(0.1, 0.07, 0.05, 1.0), (0.12, 0.08, 0.05, -0.5)]


def maps():
    rng = np.random.default_rng(5)
    k = rng.uniform(-200.0, 1500.0, (12, 16))  # <= 0 and > K_max cells: off and clipped at K_max
    k[3, 4] = np.nan
    h = np.outer(np.hanning(12), np.hanning(16)) * 0.02
    alpha = RectsField([(0.0, 0.0, 0.1, 0.148, Ramp(True, -1.5, 1.0)), (0.05, 0.1, 0.2, 0.148, Ramp(False, 0.2, 0.9)),
                        (0.15, 0.0, 0.2, 0.05, 0.3)])
    return k, h, alpha


def effects():
    k, h, alpha = maps()
    return [Stiffness(GridField(k, 0.0, 0.0, W, H)), Shape(GridField(h, 0.0, 0.0, W, H), scale=0.8),
            Roughness(2e-4, 1.5e-3), Sliding(alpha, nu=15.0, mass=FALCON.moving_mass), Attraction(POINTS)]


def bilinear(a, x, y):
    """scipy's linear interpolation between pixel centres, held constant over the border half pixel."""
    ny, nx = a.shape
    u = np.clip(x / W * nx - 0.5, 0.0, nx - 1)
    v = np.clip(y / H * ny - 0.5, 0.0, ny - 1)
    inside = (0.0 <= x) & (x <= W) & (0.0 <= y) & (y <= H)
    return np.where(inside, RegularGridInterpolator((np.arange(ny), np.arange(nx)), a)((v, u)), np.nan)


def ramp_alpha(x, y):
    """The alpha map above by hand: the last rectangle containing the point wins."""
    out = np.full(x.shape, np.nan)
    for x0, y0, x1, y1, val in ((0.0, 0.0, 0.1, 0.148, lambda: -1.5 + 2.5 * (x - 0.0) / 0.1),
                                (0.05, 0.1, 0.2, 0.148, lambda: 0.2 + 0.7 * (y - 0.1) / 0.048),
                                (0.15, 0.0, 0.2, 0.05, lambda: np.full(x.shape, 0.3))):
        inside = (x0 <= x) & (x <= x1) & (y0 <= y) & (y <= y1)
        out = np.where(inside, val(), out)
    return out


def attraction(fx, fy):
    """The CHOICE of surfhap.ff.effects.Attraction: towards each point within its radius, from 0
    at the radius to its strength at half the radius, then held."""
    f, hit = np.zeros(2), False
    for x, y, r, strength in POINTS:
        d = math.dist((x, y), (fx, fy))
        if 0.0 < d < r:
            f += strength * min(1.0, 2.0 * (r - d) / r) * np.array([x - fx, y - fy]) / d
            hit = True
    return f, hit


def test_fields_match_independent_references():
    k, _, alpha = maps()
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-0.01, W + 0.01, 3000), rng.uniform(-0.01, H + 0.01, 3000)
    grid = GridField(k, 0.0, 0.0, W, H)
    got = np.array([grid.value(a, b) for a, b in zip(x, y)])
    np.testing.assert_allclose(got, bilinear(k, x, y), rtol=1e-12, atol=1e-9, equal_nan=True)
    got = np.array([alpha.value(a, b) for a, b in zip(x, y)])
    np.testing.assert_allclose(got, ramp_alpha(x, y), rtol=1e-12, atol=1e-12, equal_nan=True)


def test_merged_terms_of_every_effect_match_their_laws():
    """Eqs. 1-4 and the attraction CHOICE (004 Sec. 3, 6; readings in surfhap.ff.effects), merged
    per eq. 8 (per axis the most compliant stiffness, offsets and forces summed), over random
    states: what the compiled tick evaluates, against the laws written out here."""
    k, h, _ = maps()
    eng = FFEngine(effects(), FALCON, TouchPredictor())
    rng = np.random.default_rng(2)
    phase = 0.0
    masks = set()
    for _ in range(400):
        s = TickState()
        s.touched = True
        s.fx, s.fy = rng.uniform(0.0, W), rng.uniform(0.0, H)
        if rng.random() < 0.3:  # near the attraction points
            s.fx, s.fy = np.clip(0.1 + rng.normal(0, 0.02), 0, W), np.clip(0.07 + rng.normal(0, 0.02), 0, H)
        s.fvx, s.fvy, s.fax, s.fay = rng.normal(0, 0.1, 4)
        s.speed = math.hypot(s.fvx, s.fvy)
        s.vx, s.vy = rng.normal(0, 0.05, 2)
        got = eng.merge(s)
        masks.add(eng.mask)
        kmat = float(bilinear(k, np.array(s.fx), np.array(s.fy)))
        a = float(np.clip(ramp_alpha(np.array(s.fx), np.array(s.fy)), -1.0, 1.0))
        phase = (phase + 2 * np.pi * s.speed * s.dt / 1.5e-3) % (2 * np.pi)
        fa, hit = attraction(s.fx, s.fy)
        on = [kmat > 0, True, True, not np.isnan(a), hit]
        stiff = [(KM, KM, min(kmat, KM)), (KM, KM, KM), (KM, KM, KM), (0.0, 0.0, KM), (KM, KM, KM)]
        kx, ky, kz = (min([KM] + [st[i] for st, o in zip(stiff, on) if o]) for i in range(3))
        hh = 0.8 * float(bilinear(h, np.array(s.fx), np.array(s.fy)))
        slide = 15.0 * (a * np.array([s.fvx, s.fvy]) - [s.vx, s.vy]) + a * FALCON.moving_mass * np.array([s.fax, s.fay])
        force = (slide if on[3] else np.zeros(2)) + fa
        expected = [kx, ky, kz, hh, 2e-4 * math.sin(phase), force[0], force[1], 0.0]
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)
        assert eng.mask == sum(1 << i for i, o in enumerate(on) if o)
    assert len(masks) > 4  # effects came and went over the maps


class Wrapped(Effect):
    """A Python effect (no packed law) with the terms of a built-in one."""

    def __init__(self, inner):
        self.inner, self.name, self.vibration = inner, inner.name, inner.vibration
        super().__init__()

    def reset(self):
        self.inner.reset()

    def terms(self, s):
        return self.inner.terms(s)


def stroke(eng, n=3000):
    out, masks = np.empty((n, 3)), np.empty(n, dtype=int)
    for k in range(n):
        t = k * 1e-3
        if k % 16 == 0:
            eng.touch(t, 0.1 + 0.03 * math.sin(math.pi * t), 0.07, 1.0 if k < 2500 else 0.0)
        p = 0.001 * math.sin(7.0 * t)
        out[k] = eng.tick(t, p, -p, -0.001, t)
        masks[k] = eng.mask
    return out, masks


def test_python_effects_merge_in_their_place():
    """Any Effect subclass runs its terms in Python and merges at its index, as a built-in one does."""
    def engine(effs):
        return FFEngine(effs, FALCON, TouchPredictor(latency=0.04, alpha=0.15, velocity_alpha=0.45), touch_latency=0.04)

    force, mask = stroke(engine(effects()))
    mixed = effects()
    mixed[2], mixed[3] = Wrapped(mixed[2]), Wrapped(mixed[3])
    eng = engine(mixed)
    assert [i for i, _ in eng._python] == [2, 3]
    force_py, mask_py = stroke(eng)
    np.testing.assert_allclose(force_py, force, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(mask_py, mask)
    assert (mask == 0b11111).any() and (mask == 0).any()


def test_a_tick_of_built_in_effects_runs_no_python_code():
    eng = FFEngine(effects(), FALCON, TouchPredictor(latency=0.04, alpha=0.15, velocity_alpha=0.45), touch_latency=0.04)
    stroke(eng, 200)  # compiled, touched, effects on
    assert bin(eng.mask).count("1") >= 3
    calls = []

    def profile(frame, event, arg):
        if event == "call":
            calls.append(f"{os.path.basename(frame.f_code.co_filename)}:{frame.f_code.co_name}")

    sys.setprofile(profile)
    try:
        eng.tick(0.2, 0.0, 0.0, -0.001, 0.2)
    finally:
        sys.setprofile(None)
    # numba reports a compiled function's entry to a profiler as a call: the engine's tick and
    # the one kernel it calls, nothing else (old code: observe, merge, every effect and field)
    assert calls == ["engine.py:tick", "tick_kernel.py:tick"], calls
    assert bin(eng.mask).count("1") >= 3


def test_switch_packs_in_the_caller_and_the_tick_takes_it():
    eng = FFEngine(effects(), FALCON, TouchPredictor(), touch_latency=0.0)
    stroke(eng, 100)
    eng.switch([Stiffness(300.0)])
    assert len(eng.effects) == 5  # taken by the next tick, not before
    eng.tick(0.1, 0.0, 0.0, 0.0, 0.1)
    assert [e.name for e in eng.effects] == ["stiffness"] and eng.E.shape == (1, 6)


def test_a_rectangle_value_is_a_number_or_a_ramp():
    with pytest.raises(TypeError):
        RectsField([(0.0, 0.0, 1.0, 1.0, lambda x, y: 1.0)])
