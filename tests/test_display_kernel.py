"""The simulated display's kernel against an independent reference: the leakage high-pass
``V_eff[n] = a (V_eff[n-1] + v[n] - v[n-1])`` is scipy.signal.lfilter([a, -a], [1, -a]), the
friction eq. 5 of Otake et al. 2022 (``mu (fn + k V_eff^2)``, 0 without contact) written out in
numpy, decimated by a fresh resampler (itself checked against upfirdn in test_offline_kernels)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from surfhap.models.panel import DisplayModel, SimulatedDisplay
from surfhap.signal.resample import RationalResampler

FS, FR = 20000, 2000


def _reference(model, drive, load, gain):
    tau = model.leakage_time_constant
    a = tau / (tau + 1.0 / FS)
    ve = lfilter([a, -a], [1.0, -a], drive)  # starts from rest: v[-1] = V_eff[-1] = 0
    force = np.where(load > 0.0, model.mu_panel * load + model.mu_panel * model.k * ve ** 2 * gain, 0.0)
    return RationalResampler(FS, FR).process(force)


@pytest.mark.parametrize("per_sample_gain", [False, True])
@pytest.mark.parametrize("blocks", [(7,), (1, 2, 3), (1023, 1, 1025, 2048, 3), (5001,)])
def test_friction_equals_lfilter_reference_for_any_block_split(blocks, per_sample_gain):
    rng = np.random.default_rng(sum(blocks))
    n = sum(blocks)
    t = np.arange(n) / FS
    # a polarity-switched envelope, a DC stretch (the fading the high-pass models) and lifts
    drive = 200.0 * np.abs(np.sin(2 * np.pi * 30 * t)) * np.where((np.arange(n) // 5) % 2, -1.0, 1.0)
    drive[n // 3: n // 2] = 150.0
    load = np.where(rng.random(n) < 0.05, 0.0, 0.3 + 0.1 * rng.random(n))
    gain = 0.5 + rng.random(n) if per_sample_gain else np.full(n, 0.8)
    model = DisplayModel(leakage_time_constant=0.01)
    display = SimulatedDisplay(model, FS, FR)
    out, i = [], 0
    for b in blocks:
        out.append(display.process(drive[i:i + b], load[i:i + b], gain[i:i + b] if per_sample_gain else np.array([0.8])))
        i += b
    got = np.concatenate(out)
    want = _reference(model, drive, load, gain)
    assert got.shape == want.shape
    rms = np.sqrt(np.mean(want ** 2))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * rms)
