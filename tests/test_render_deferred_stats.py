"""A render whose arrays are kept does not reduce them at its end: its statistics are
reduced when first read (RenderStats.add_blocks(defer=True); the counts at once), and then
equal the same statistics written out in numpy over the returned arrays; a streamed render
(no arrays kept) reduces them per block and gives the same figures."""

import copy

import numpy as np
import pytest

from surfhap import ChainConfig, load_material, strokes
from surfhap.render.offline import RenderStats
from surfhap.runtime.offline import stream_render
from surfhap.texture import render


def numpy_stats(r) -> dict:
    on = r.load > 0
    sat = on & (r.voltage >= r.v_max)
    low = r.low_band.force(r.load, r.mu_low)
    return {"n_model": r.speed.size, "n_drive": r.drive.size, "max_abs_drive": float(np.max(np.abs(r.drive))),
            "friction_sum": float(np.sum(r.friction_sim)), "touching": int(np.sum(on)),
            "onset_load": float(np.min(r.load[sat])) if sat.any() else None,
            "target_sum": float(np.sum(r.target[on])), "texture_sq_sum": float(np.sum((r.target[on] - low[on]) ** 2))}


@pytest.mark.parametrize("alpha", [None, 700.0])  # planned; a gain that saturates (an onset load)
def test_kept_render_defers_its_statistics_and_they_are_exact_when_read(monkeypatch, alpha):
    calls = []
    add_drive = RenderStats.add_drive
    monkeypatch.setattr(RenderStats, "add_drive", lambda self, d: (calls.append(d.size), add_drive(self, d))[1])
    leather = load_material("leather")
    r = render(leather, strokes(0.1, 0.4, 2.0), ChainConfig(drive_rate=20000, alpha=alpha), block_seconds=0.5)
    assert r.n_model == r.speed.size and r.t_drive.size == r.drive.size  # the counts are kept at once
    assert calls == [] and r.stats.pending  # nothing reduced yet
    ref = numpy_stats(r)
    assert (alpha is not None) == (ref["onset_load"] is not None)
    got = {k: getattr(copy.copy(r.stats), k) for k in ref}  # a copy (or pickle) reduces the whole render once, first
    assert calls == [r.drive.size] and not r.stats.pending
    for key, value in ref.items():
        assert got[key] == (value if value is None else pytest.approx(value, rel=1e-12)), key
    s = r.summary()
    assert s["max_abs_voltage"] == ref["max_abs_drive"] and s["saturation_onset_load_n"] == ref["onset_load"]
    assert calls == [r.drive.size]  # read once
    streamed = stream_render(leather, strokes(0.1, 0.4, 2.0), ChainConfig(drive_rate=20000, alpha=alpha), None,
                             block_seconds=0.5)
    assert len(calls) > 2 and not streamed.stats.pending  # per block, at once
    for key, value in ref.items():
        assert getattr(streamed.stats, key) == (value if value is None else pytest.approx(value, rel=1e-12)), key
