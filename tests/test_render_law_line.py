"""The render figure's law line is the law the method uses, and a render whose texture is under
1 % of its target says so (issue 17, item 13: zhao drew a line 47 % off its own friction)."""

import json

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.materials import load_material
from surfhap.models.trajectory import constant_scan
from surfhap.render.chain import ChainConfig
from surfhap.runtime.offline import render, stream_render
from surfhap.report.figures import law_line

ZHAO_LOAD = 1.6  # N, Zhao et al.'s constant load (ChainConfig.constant_load)


@pytest.fixture(scope="module")
def leather():
    return load_material("leather")


@pytest.mark.parametrize("method", ["zhao", "otake2022", "otake2021", "friction-only", "square"])
def test_law_line_follows_the_simulated_mean_friction(leather, method):
    traj = constant_scan(0.12, 0.4, 3.0)  # 0.4 N: not Zhao's 1.6 N, where the old line went wrong
    cfg = ChainConfig(method=method, seed=2)
    r = render(leather, traj, cfg)
    streamed = stream_render(leather, traj, cfg, lambda channel, block: None, block_seconds=0.7)
    for pv in (r.preview, streamed.preview):  # the in-memory figure and the one `surfhap render` draws
        line = law_line(pv)
        assert line.shape == pv.win_t.shape and np.all(pv.win_load > 0)
        # the tolerance: the textural force in the window (the friction deviates from the low band by
        # the texture; its window mean by a fraction of its rms), plus 0.5 % for the display's dynamics
        textural = pv.rendering_gain * (pv.win_target - pv.win_low)
        if method == "square":  # the square wave is its own "texture" around its mean
            textural = pv.rendering_gain * (pv.win_target - np.mean(pv.win_target))
        tol = 3 * float(np.sqrt(np.mean(textural ** 2))) / np.sqrt(pv.win_t.size / 50) + 0.005 * float(np.mean(line))
        assert abs(float(np.mean(pv.win_friction)) - float(np.mean(line))) < tol, (method, tol)
    if method == "zhao":  # an independent reference: Zhao's mu0 at his 1.6 N, scaled by the rendering gain
        expected = r.mu_panel * 0.4 + r.rendering_gain * leather.coulomb.mu0 * ZHAO_LOAD
        assert float(np.mean(law_line(r.preview))) == pytest.approx(expected, rel=1e-9)


def test_a_texture_under_one_percent_is_reported_in_one_line(tmp_path, capsys, leather):
    out = tmp_path / "z"
    code = main(["render", "leather", "--method", "zhao", "--scan", "speed=0.12,load=0.4,duration=2", "--out", str(out),
                 "--no-figure"])
    err = capsys.readouterr().err
    assert code == 0
    lines = [ln for ln in err.splitlines() if "texture is" in ln]
    assert len(lines) == 1 and "under 1%" in lines[0] and "zhao" in lines[0], err
    s = json.loads((out / "summary.json").read_text())
    assert s["texture_warning"] and s["texture_share"] < 0.01
    # the share against an independent computation from the written channels
    data = np.load(out / "render.npz")
    touching = data["load"] > 0
    target = data["target"][touching].astype(float)
    textural = target - data["mu_low"][touching] * ZHAO_LOAD
    assert s["texture_share"] == pytest.approx(np.sqrt(np.mean(textural ** 2)) / np.mean(target), rel=1e-3)
    # the calibrated method on the same material: no such line
    code = main(["render", "leather", "--scan", "speed=0.12,load=0.4,duration=2", "--out", str(tmp_path / "o"),
                 "--no-figure"])
    err = capsys.readouterr().err
    assert code == 0 and "texture is" not in err
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["texture_warning"] is None and s["texture_share"] > 0.01
