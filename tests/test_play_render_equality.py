"""``surfhap play --clock sim`` and ``surfhap render`` run one runtime: on the same touch samples
and seed they write the same drive samples (issue 20: they used to differ by a 10-sample lag,
RMS 128.3 vs 129.7 V).

``play --trajectory T --clock sim --output file:X.npz`` goes through the live engine (touch
ring, per-model-sample hold at the arrival stamps, drive FIFO, output safety pass, file
backend); ``render`` through the offline render and its render.npz. The drive of ``render`` is
the reference: the first samples of the play recording must equal it within 1e-6 V, and what
follows is the stop ramp down to 0 V.
"""

from __future__ import annotations

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.trajectory_csv import write_trajectory_csv
from surfhap.models.trajectory import Trajectory, constant_scan, strokes


def _jittered(speed: float, load: float, duration: float, seed: int) -> Trajectory:
    """A recording-like finger: irregular sensor stamps (90-160 Hz), a back-and-forth stroke."""
    rng = np.random.default_rng(seed)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(1 / 160, 1 / 90, int(duration * 130)))])
    x = 0.02 + 0.04 * (1 - np.cos(speed * t / 0.04))
    return Trajectory(t, x, np.full(t.size, 0.03), np.full(t.size, load), name="jittered")


def _lifts(speed: float, load: float, duration: float) -> Trajectory:
    """Slides with lifts and a 0.2 s gap: the finger leaves and comes back elsewhere."""
    t = np.arange(0.0, duration, 1 / 125)
    t = np.concatenate([t[t < 0.3], t[t >= 0.5]])  # no samples for 0.2 s
    x = 0.02 + speed * t
    load_n = np.where((t > 0.6) & (t < 0.75), 0.0, load)
    return Trajectory(t, x, np.full(t.size, 0.03), load_n, name="lifts")


CASES = [  # (trajectory, material, drive rate)
    (lambda: strokes(0.05, 0.3, 0.8, length=0.02), "cork", 20000),
    (lambda: constant_scan(0.5, 0.9, 0.6), "cork", 48000),
    (lambda: strokes(1.0, 0.6, 0.6, length=0.1), "denim", 20000),
    (lambda: _jittered(0.2, 0.96, 0.7, 3), "leather", 48000),
    (lambda: _jittered(0.8, 0.26, 0.5, 4), "denim", 32000),
    (lambda: _lifts(0.3, 0.7, 1.2), "leather", 20000),
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_play_on_a_simulated_clock_writes_the_drive_of_render(tmp_path, capsys, case):
    make, material, rate = CASES[case]
    traj = make()
    path = write_trajectory_csv(traj, tmp_path / "t.csv")
    common = ["--trajectory", str(path), "--drive-rate", str(rate), "--seed", "7"]
    assert main(["render", material, *common, "--out", str(tmp_path / "r"), "--no-figure"]) == 0, capsys.readouterr().err
    assert main(["play", material, *common, "--clock", "sim", "--output", f"file:{tmp_path / 'x.npz'}"]) == 0, \
        capsys.readouterr().err
    with np.load(tmp_path / "r" / "render.npz") as z:
        want = np.asarray(z["drive"], dtype=float)
    with np.load(tmp_path / "x.npz") as z:
        got = np.asarray(z["drive"], dtype=float)
        assert int(z["drive_rate"]) == rate
    assert np.sqrt(np.mean(want ** 2)) > 10.0  # a real drive, not two silences
    assert got.size >= want.size
    np.testing.assert_allclose(got[: want.size], want, rtol=0, atol=1e-6)
    tail = got[want.size:]
    assert tail.size <= int(0.010 * rate) + 8 * int(0.001 * rate) and (tail.size == 0 or tail[-1] == 0.0)


def test_a_simulated_clock_needs_a_trajectory_and_a_block_driven_output(capsys):
    assert main(["serve", "--clock", "sim"]) == 2
    assert "--trajectory" in capsys.readouterr().err
    assert main(["play", "cork", "--clock", "moon"]) == 2
    assert "--clock" in capsys.readouterr().err
