"""The per-sample kernels of an offline render, made faster for the 20 kHz benchmark, against
independent references: the quasi-static law (recomputed only when the held finger state
changes) against numpy's evaluation of eq. 3 of 003, the polarity carrier (a float floor in
place of the modulo) against Python's modulo, the resampler (vector loads, one filter design
per conversion) against scipy's upfirdn and against itself over any block split, and the
kept render arrays (rows of one allocation) independent of each other."""

import numpy as np
import pytest
from scipy.signal import upfirdn

from surfhap import ChainConfig, load_material, strokes
from surfhap.render.carrier import polarity
from surfhap.render.drive_kernel import TEXTURE_COF, friction_texture_law
from surfhap.signal.resample import RationalResampler
from surfhap.texture import render


def test_quasi_static_law_over_held_and_changing_finger_states():
    a, b, c, d, q = 0.8, -0.3, 4.0, 2.5, 0.7
    rng = np.random.default_rng(3)
    # touch samples held over runs of model samples, a state that comes back (A B A), lifts, NaN, negative speeds
    runs = rng.integers(1, 20, 60)
    load = np.repeat(rng.uniform(0.05, 1.5, runs.size), runs)
    speed = np.repeat(rng.uniform(-0.3, 0.3, runs.size), runs)
    load[:5], load[40:45], speed[40:45] = load[60], load[60], speed[60]
    load[100:110] = 0.0
    load[200:203] = np.nan
    speed[300:305] = np.nan
    texture = rng.standard_normal(load.size) * 0.01
    out = np.empty((4, load.size))
    friction_texture_law(load, speed, texture, True, a, b, c, d, q, 0.0, TEXTURE_COF, 1.0, 1.8, 100.0, out)
    s = np.abs(speed)
    with np.errstate(invalid="ignore"):
        ref = np.where(load > 0, a * np.maximum(load, 1e-300) ** b * (1 + d * s ** q) / (1 + c * s), 0.0)
    np.testing.assert_allclose(out[2], ref, rtol=1e-15, atol=0)
    np.testing.assert_allclose(out[1], (ref + 1.8 * texture) * load, rtol=1e-14, atol=1e-300)


@pytest.mark.parametrize("step", [0.1, 2000 / 44100, 20000 / 40000, 0.0, 1 / 3])
@pytest.mark.parametrize("n0", [0, 7, 123_456_789])
def test_polarity_is_the_sign_of_the_carrier_phase(step, n0):
    env = np.random.default_rng(1).uniform(0, 200, 997)
    out = np.empty_like(env)
    polarity(env, float(n0), step, out)
    sign = np.array([1.0 if ((n0 + i) * step) % 1.0 < 0.5 else -1.0 for i in range(env.size)])
    assert np.array_equal(out, sign * env)


@pytest.mark.parametrize("rates", [(2000, 20000), (20000, 2000), (2000, 44100), (44100, 2000), (100, 2000)])
def test_resampler_equals_upfirdn_and_any_block_split(rates):
    rate_in, rate_out = rates
    x = np.random.default_rng(2).standard_normal(30_000 if rate_in > rate_out else 3_000)
    r = RationalResampler(rate_in, rate_out)
    again = RationalResampler(rate_in, rate_out)
    assert again._Hr is r._Hr and not r._Hr.flags.writeable  # designed once per conversion, shared read-only
    whole = r.process(x)
    split, i = [], 0
    for n in np.random.default_rng(5).integers(1, 2_500, 400):
        split.append(again.process(x[i:i + n]))
        i += n
    assert np.array_equal(np.concatenate(split), whole)
    h = r._H.T.reshape(-1)  # the prototype filter, h[k L + ph] = branch ph tap k
    ref = upfirdn(h, x, up=r.L, down=r.M)[:whole.size]
    np.testing.assert_allclose(whole, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))


def test_kept_render_arrays_are_independent():
    res = render(load_material("cork"), strokes(0.1, 0.4, 1.5), ChainConfig(), block_seconds=0.3)
    names = ("speed", "load", "texture", "mu_low", "mu_tex", "target", "voltage", "friction_sim")
    before = {k: getattr(res, k).copy() for k in names}
    res.speed[:] = np.nan
    for k in names[1:]:
        assert np.array_equal(getattr(res, k), before[k])
        assert getattr(res, k).shape == (res.n_model,)
