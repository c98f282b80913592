"""The runtime's pieces against independent references: the touch hold (a sample in force
from the model sample at its stamp) against numpy's searchsorted, the simulated clock's
delivery at the stamps, and the protocols the live pieces implement."""

from __future__ import annotations

import numpy as np

from surfhap.models.trajectory import Trajectory
from surfhap.render.hold import NO_TOUCH_TIME, TouchHold, TrajectoryRows
from surfhap.render.kinematics import TouchPredictor
from surfhap.runtime.clock import SimClock, WallClock
from surfhap.runtime.protocols import Sink, Source


def _hold(traj, rate, block):
    hold = TouchHold(TrajectoryRows(traj), TouchPredictor(), 0.05, capacity=16)  # small: the buffer refills mid-block
    hold.take(0.0, 0.0)
    n = int(np.floor((traj.t[-1] - traj.t[0]) * rate)) + 1
    cols = np.empty((5, n))
    for s in range(0, n, block):
        k = min(n, s + block) - s
        hold.fill(s, rate, cols[:, s:s + k])
    return n, cols


def test_the_hold_puts_each_sample_in_force_from_the_model_sample_at_its_stamp():
    rng = np.random.default_rng(2)
    t = 0.3 + np.cumsum(rng.uniform(0.0002, 0.012, 300))  # irregular, several per model sample at times
    load = np.where(rng.uniform(size=t.size) < 0.1, 0.0, rng.uniform(0.2, 1.0, t.size))
    traj = Trajectory(t, rng.uniform(0, 0.1, t.size), rng.uniform(0, 0.1, t.size), load, name="random")
    for rate, block in ((2000, 7), (1000, 1000), (20000, 4096)):
        n, (speed, held, touch_time, x, _) = _hold(traj, rate, block)
        rel = traj.t - traj.t[0]
        k = np.searchsorted(rel, np.arange(n) / rate + 1e-12, side="right") - 1  # reference
        np.testing.assert_array_equal(held, np.where(traj.load[k] > 0, traj.load[k], 0.0))
        np.testing.assert_array_equal(touch_time, rel[k])
        on = traj.load[k] > 0
        np.testing.assert_array_equal(x[on], traj.x[k][on])
        assert np.all(speed[~on] == 0.0) and np.all(touch_time > NO_TOUCH_TIME)


def test_clocks_and_protocols():
    c = SimClock(5.0)
    assert c.simulated and c.wait_until(7.5) == 7.5 and c.now() == 7.5 and c.wait_until(6.0) == 7.5
    assert not WallClock().simulated
    from surfhap.live.backends.output import SimOutput, open_backend
    from surfhap.live.sources import ReplaySource

    assert isinstance(open_backend(SimOutput()), Sink)
    assert isinstance(ReplaySource(None, None), Source)
