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
    from surfhap.runtime.sources import TrajectorySource

    assert isinstance(open_backend(SimOutput()), Sink)
    tr = Trajectory(np.arange(3.0), np.zeros(3), np.zeros(3), np.ones(3))
    assert isinstance(TrajectorySource(None, tr), Source) and isinstance(TrajectorySource(None, tr, wall_clock=True), Source)


class _Sink:
    def __init__(self):
        self.got = []

    def push_touch(self, source, x, y, load, t_event=float("nan"), t_arrival=None):
        self.got.append((source, x, y, load, t_event, t_arrival))
        return True


def test_one_replay_on_a_simulated_and_on_a_wall_clock():
    """The same source replays a trajectory at its stamps on either clock: every sample once,
    in order, then one lift one sample period after the last; looped, lap k at k periods."""
    from surfhap.runtime.sources import TrajectorySource

    rng = np.random.default_rng(4)
    t = 5.0 + np.cumsum(rng.uniform(0.0005, 0.002, 25))
    traj = Trajectory(t, rng.uniform(0, 0.1, t.size), rng.uniform(0, 0.1, t.size), rng.uniform(0.1, 1, t.size))
    rel = t - t[0]
    lift = rel[-1] + (rel[-1] - rel[-2])
    expected = [(7, traj.x[i], traj.y[i], traj.load[i], rel[i]) for i in range(t.size)] + [(7, 0.0, 0.0, 0.0, lift)]

    sim = _Sink()
    src = TrajectorySource(sim, traj, source=7)
    src.start()
    for until in np.arange(0.0, lift + 0.01, 0.003):
        src.deliver(until)
        assert all(g[4] <= until for g in sim.got)  # nothing before its time
    assert [g[:5] for g in sim.got] == expected and all(g[5] == g[4] for g in sim.got)
    assert src.sent == t.size and src.done.is_set()

    wall = _Sink()
    src = TrajectorySource(wall, traj, source=7, wall_clock=True)
    src.start()
    assert src.done.wait(30.0)  # a failure guard, not a timing assertion
    src.stop()
    assert [g[:4] for g in wall.got] == [e[:4] for e in expected] and src.sent == t.size
    np.testing.assert_allclose([g[4] for g in wall.got[:-1]], rel)  # event stamps; the receiver stamps arrival
    assert all(g[5] is None for g in wall.got)

    looped = _Sink()
    src = TrajectorySource(looped, traj, source=7, loop=True, max_seconds=2.5 * lift)
    src.start()
    src.deliver(10.0)
    stamps = [g[4] for g in looped.got[:-1]]
    ref = [k * lift + r for k in range(3) for r in rel if k * lift + r <= 2.5 * lift]
    np.testing.assert_allclose(stamps, ref)
    assert looped.got[-1][1:4] == (0.0, 0.0, 0.0) and src.done.is_set()


def test_a_wall_clock_replay_stopped_early_ends_with_a_lift():
    import time

    from surfhap.runtime.sources import TrajectorySource

    t = np.arange(0.0, 20.0, 0.01)
    sink = _Sink()
    src = TrajectorySource(sink, Trajectory(t, np.full(t.size, 0.05), np.full(t.size, 0.05), np.ones(t.size)),
                           wall_clock=True)
    src.start()
    end = time.monotonic() + 30.0  # failure guard only
    while src.sent < 3 and time.monotonic() < end:
        time.sleep(0.005)
    src.stop()
    assert src.done.is_set() and 3 <= src.sent < t.size
    assert sink.got[-1][1:4] == (0.0, 0.0, 0.0) and len(sink.got) == src.sent + 1
