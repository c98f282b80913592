"""The screen stays inside the workspace and is put down, not dropped (issue 17, items 3 and 8).

Closed loop with the simulated device (:mod:`surfhap.sim.ff_device`) and finger: random
swipes up to 1 m/s over every built-in scene never take the screen beyond the workspace wall
and reach the wall's last ``brake_margin`` at no more than 0.05 m/s; on stop the tablet sinks
no faster than its weight against the landing damping, and a scene switch keeps the weight
compensation up.
"""

import numpy as np
import pytest

from surfhap.ff import FALCON, FFEngine
from surfhap.ff.params import GRAVITY
from surfhap.ff.scene import builtin_scene_names, load_scene
from surfhap.render.kinematics import TouchPredictor
from surfhap.models.trajectory import Trajectory
from surfhap.sim.ff_device import SimDevice, SimFinger
from surfhap.live.ff_loop import simulate_ff

RATE = 1000.0
ARRIVAL = 0.05  # m/s, largest speed towards a wall within its last brake_margin


def swipes(rng, size, dur=2.5, v_max=1.0):
    """Straight swipes in random directions at random speeds up to v_max, 0.1-0.6 s each,
    bouncing off the scene's edges; one random load for the whole run."""
    n = int(dur * RATE)
    t = np.arange(n) / RATE
    xy = np.empty((n, 2))
    p = np.array([rng.uniform(0.02, size[0] - 0.02), rng.uniform(0.02, size[1] - 0.02)])
    v = np.zeros(2)
    nxt = 0
    for i in range(n):
        if i == nxt:
            a = rng.uniform(0.0, 2 * np.pi)
            v = rng.uniform(0.05, v_max) * np.array([np.cos(a), np.sin(a)])
            nxt = i + int(rng.integers(100, 600))
        p = p + v / RATE
        for j in range(2):
            if not 0.0 <= p[j] <= size[j]:
                v[j] = -v[j]
                p[j] = min(max(p[j], 0.0), size[j])
        xy[i] = p
    return Trajectory(t, xy[:, 0], xy[:, 1], np.full(n, rng.uniform(0.3, 1.5)), name="random swipes")


def engine(scene):
    return FFEngine(scene.effects, FALCON, TouchPredictor(latency=0.04, alpha=0.15, velocity_alpha=0.45), rate=RATE,
                    touch_latency=0.04, buttons=scene.buttons)


@pytest.mark.parametrize("name", builtin_scene_names())
@pytest.mark.parametrize("seed", [0, 1])
def test_random_swipes_never_cross_the_wall_and_arrive_slowly(name, seed):
    rng = np.random.default_rng([seed, sum(map(ord, name))])
    sc = load_scene(name, FALCON)
    res = simulate_ff(engine(sc), SimFinger(swipes(rng, sc.size), latency=0.04, mu=rng.uniform(0.0, 0.5)),
                      SimDevice(gain=FALCON.gain))
    ws = np.asarray(FALCON.workspace)
    p, v = res.screen, res.screen_v
    assert np.all(np.abs(p) <= ws), f"{name}: {1e3 * np.max(np.abs(p) - ws):.2f} mm beyond the wall"
    near = np.abs(p) >= ws - FALCON.brake_margin
    toward = np.where(near, v * np.sign(p), 0.0)
    assert toward.max() <= ARRIVAL, f"{name}: {toward.max():.3f} m/s into the wall"


def test_sliding_strips_fit_the_workspace():
    """Follow / Reverse move the screen as far as the finger strokes: their regions are no
    wider than the workspace (2 x 40 mm)."""
    for name in ("follow", "reverse"):
        sc = load_scene(name, FALCON)
        xs = np.linspace(0.0, sc.size[0], 2001)
        alpha = sc.effects[0].alpha
        inside = xs[[alpha.value(x, sc.size[1] / 2) == alpha.value(x, sc.size[1] / 2) for x in xs]]
        assert inside.size and inside.max() - inside.min() <= 2 * FALCON.workspace[0] + 1e-9


def _hold_then(eng, dev, ticks, action_at, action, load=0.0):
    cmd = np.zeros(3)
    ext = np.array([0.0, 0.0, -load])
    vz, fz = np.zeros(ticks), np.zeros(ticks)
    for k in range(ticks):
        t = k / RATE
        if k == action_at:
            action()
        f = eng.tick(t, float(dev.p[0]), float(dev.p[1]), float(dev.p[2]), t)
        cmd[:] = f * FALCON.gain
        dev.step(cmd, ext)
        vz[k], fz[k] = dev.v[2], f[2]
    return vz, fz


def test_stop_puts_the_tablet_down_instead_of_dropping_it():
    """Without compensation the tablet falls from X0 onto the end stop at sqrt(2 g 5 cm) ~ 1 m/s.
    With the compensation lowered over land_time against land_damping, it can sink no faster
    than its weight / land_damping (the terminal speed: 0.19 m/s for the Falcon's numbers)."""
    sc = load_scene("buttons", FALCON)
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), rate=RATE)
    dev = SimDevice(rate=RATE, gain=FALCON.gain)
    stop_at = 500
    vz, fz = _hold_then(eng, dev, 3500, stop_at, eng.stop)
    assert abs(vz[stop_at - 1]) < 1e-3  # held still before the stop
    terminal = FALCON.moving_mass * GRAVITY / 20.0  # 20 N s/m: the Falcon's largest damping (CHAI3D)
    assert -vz[stop_at:].min() <= terminal, f"fell at {-vz[stop_at:].min():.2f} m/s"
    # the compensation goes down over >= 1 s, then the output ends at zero
    assert np.all(fz[stop_at:stop_at + int(RATE)] > 0.0)
    assert fz[-1] == 0.0
    steps = np.abs(np.diff(fz))
    assert steps.max() <= FALCON.slew / RATE + 1e-9


def test_scene_switch_keeps_the_weight_compensation_up():
    """Switching scenes between trials keeps the tablet held: the vertical force stays at the
    weight and the tablet does not sink."""
    eng = FFEngine(load_scene("buttons", FALCON).effects, FALCON, TouchPredictor(), rate=RATE)
    dev = SimDevice(rate=RATE, gain=FALCON.gain)
    other = load_scene("mall", FALCON)
    vz, fz = _hold_then(eng, dev, 1500, 700, lambda: eng.switch(other.effects, other.buttons))
    w = FALCON.moving_mass * GRAVITY
    assert np.all(np.abs(fz[300:] - w) < 0.05 * w)
    assert np.abs(vz[300:]).max() < 1e-3
