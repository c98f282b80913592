"""The reference test of the safety promise: hypothesis drives the WHOLE live engine.

Arbitrary sequences of touch (any x, y, load, including NaN, inf and huge values), stale
touch data, lift (also lift and re-touch within one block), gain (any float), renderer /
material / method switch, stall (the clock jumps while touch data queues up), stop, and
adversarial caller stamps (``t_arrival`` from the future, +inf, -inf, NaN, going backwards,
huge jumps, followed by silence), at drive rates of 20, 44.1 and 48 kHz and block periods
of 0.25-4 ms. The engine runs on a simulated clock (its ``clock``) that the producers share,
as in the real process. Every emitted sample is audited
(:func:`surfhap.live.audit.audit_drive`) independently of the engine's counters:

* finite and ``|V| <= v_max``;
* the magnitude rises by at most ``rise_rate / drive_rate`` per sample, across blocks,
  commands and switches (the stream starts from 0 V);
* watchdog: 0 V whenever the freshest touch sample handed to the engine is older than
  ``watchdog_timeout + watchdog_ramp`` at the sample's emission time; a sample is never
  younger than the engine clock at the moment it was handed over (a caller's stamp may
  make it older, never fresher);
* stop: 0 V from ``stop_ramp`` after the block that took the stop command.

``make test`` runs ``SURFHAP_SAFETY_EXAMPLES`` sequences (default 10 000, derandomized so
CI is reproducible); ``make soak`` runs many more with fresh random seeds. Renderers are
built once per drive rate (outside the examples) and reset at the start of each example.
"""

from __future__ import annotations

import functools
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

from surfhap.exchange.materials import load_material
from surfhap.live.audit import audit_drive
from surfhap.errors import ConfigError
from surfhap.live.engine import LiveEngine
from surfhap.runtime.commands import SetGain, SwapRenderer
from surfhap.live.engine_config import EngineConfig
from surfhap.render.chain import ChainConfig, TextureChain

RATES = (20000, 44100, 48000)
# material, method: a Coulomb + AR texture law, a square wave, a 100 Hz texture model
# (resampled up), Zhao et al.'s law, friction only
RENDERERS = (("cork", "auto"), ("cork", "square"), ("denim", "auto"), ("leather", "zhao"), ("wood", "friction-only"))
EXAMPLES = int(os.environ.get("SURFHAP_SAFETY_EXAMPLES", "10000"))
SOAK = os.environ.get("SURFHAP_SAFETY_SOAK", "") not in ("", "0")
STOP_RAMP = 0.010


@functools.lru_cache(maxsize=None)
def _dome():
    """A 6 cm dome (an icosphere flattened to 1.2 cm) and its calibration (Kim et al. 2017)."""
    import trimesh

    from surfhap.render.shape_renderer import ShapeConfig
    from surfhap.shape.calibration import calibrate
    from surfhap.shape.topsurface import TopSurface

    m = trimesh.creation.icosphere(subdivisions=2, radius=0.03)
    v = np.array(m.vertices)
    v[:, 2] *= 0.2
    surface = TopSurface(v, np.array(m.faces), name="dome")
    return surface, calibrate(surface, fz=ShapeConfig().fz)


@functools.lru_cache(maxsize=None)
def renderers(rate: int) -> tuple:
    """The texture chains of RENDERERS, plus the mesh renderer where the drive rate is a
    multiple of its 1 kHz touch rate (20 and 48 kHz)."""
    chains = [TextureChain(load_material(m), ChainConfig(drive_rate=rate, method=meth)) for m, meth in RENDERERS]
    if rate % 1000 == 0:
        from surfhap.render.shape_chain import ShapeChain
        from surfhap.render.shape_renderer import ShapeConfig

        surface, cal = _dome()
        chains.append(ShapeChain(surface, cal, ShapeConfig(drive_rate=rate)))
    return tuple(chains)


anything = st.floats(allow_nan=True, allow_infinity=True)
coord = st.one_of(st.floats(-0.01, 0.25), st.sampled_from([0.05, 1e300, -1e300]), anything)
load = st.one_of(st.floats(0.0, 3.0), st.sampled_from([0.5, 2.0, 0.0, 0.019, 49.0, 51.0, -1.0, 1e300]), anything)
gain = st.one_of(st.sampled_from([0.0, 1.0, 0.5]), st.floats(-0.5, 1.5), anything)
stale = st.sampled_from([0.0, 0.02, 0.049, 0.051, 0.056, 0.2, 1.2, 2.7])
stall = st.sampled_from([0.01, 0.05, 0.06, 0.3, 1.1, 2.7])

# a caller's t_arrival relative to the engine clock at hand-over (s): future, huge jumps,
# going backwards against the last stamp (the "stamp" op adds the last stamp to "back"), or
# not a number at all
STAMPS = (0.0005, 0.003, 0.06, 3.0, 1e6, 1e300, math.inf, -math.inf, math.nan, -1e300, "back")
stamp = st.one_of(st.sampled_from(STAMPS), st.floats(-5.0, 5.0), anything)

# (kind, blocks, source, x, y, load, value): value is the gain, renderer index, stall,
# staleness or caller stamp
KINDS = ("touch",) * 5 + ("stale", "lift", "lift+touch", "gain", "renderer", "stall", "stop", "idle") + ("stamp",) * 2
op = st.tuples(st.sampled_from(KINDS), st.integers(1, 6), st.sampled_from([1, 1, 1, 2]), coord, coord, load,
               st.one_of(gain, stale, stall, st.integers(0, len(RENDERERS)), stamp))


class Harness:
    """Drives one engine on a simulated clock (``self.t``, the engine's clock too) and
    records what the audit needs."""

    def __init__(self, rate: int, block: float, first: int = 0):
        self.rends = renderers(rate)
        for r in self.rends:
            r.reset()
        self.e = LiveEngine(self.rends[first], EngineConfig(block_seconds=block, stop_ramp=STOP_RAMP, trace_capacity=64,
                                                        latency_capacity=64, touch_capacity=256),
                            clock=lambda: self.t)
        self.rate = rate
        self.t = 10.0
        self.fresh = -math.inf  # reference: newest arrival of a sample handed to the engine
        self.last_stamp = self.t
        self.x = 0.05
        self.out, self.age, self.silent = [], [], []
        self.stop_pending = False
        self.silent_from = None  # global sample index from which the output must be 0
        self.n = 0

    def push(self, src, x, y, ld, t_arr=None):
        """Hand a sample over at engine time ``self.t``, with a caller's stamp ``t_arr``."""
        self.e.push_touch(src, x, y, ld, t_arrival=t_arr)
        # independent reference: a sample is at most as fresh as the moment it was handed
        # over; a caller's stamp can only make it older
        arrival = self.t if t_arr is None or not t_arr <= self.t else t_arr
        self.fresh = max(self.fresh, arrival)
        if t_arr is not None and math.isfinite(t_arr):
            self.last_stamp = t_arr

    def blocks(self, n, touch=None):
        e = self.e
        idx = np.arange(e.block_frames)
        for _ in range(n):
            if touch is not None:
                src, x, y, ld = touch
                self.x += 0.0007
                self.push(src, x + self.x if math.isfinite(x) else x, y, ld, self.t)
            if self.stop_pending and self.silent_from is None:
                self.silent_from = self.n + math.ceil(STOP_RAMP * self.rate - 1e-9)
            v = e.render(e.block_frames, self.t).copy()
            self.out.append(v)
            self.age.append(self.t + idx / self.rate - self.fresh)
            g = self.n + idx
            self.silent.append(g >= self.silent_from if self.silent_from is not None else np.zeros(v.size, bool))
            self.n += v.size
            self.t += e.block_period

    def step(self, kind, n, src, x, y, ld, value):
        touch = (src, x, y, ld)
        if kind == "touch":
            self.blocks(n, touch)
        elif kind == "stale":
            age = float(value) if isinstance(value, float) and 0 <= value <= 3 else 1.2
            self.push(src, x, y, ld, self.t - age)
            self.blocks(n)
        elif kind in ("lift", "lift+touch"):
            self.push(src, 0.0, 0.0, 0.0, self.t)
            if kind == "lift+touch":
                self.push(src, x, y, ld, self.t)
            self.blocks(n)
        elif kind == "gain":
            try:  # an invalid gain (NaN, out of range, not a number) is refused before the engine
                self.e.send(SetGain(value))
            except ConfigError:
                pass
            self.blocks(n, touch)
        elif kind == "renderer":
            self.e.send(SwapRenderer(self.rends[int(value) % len(self.rends)] if isinstance(value, int) else self.rends[0]))
            self.blocks(n, touch)
        elif kind == "stall":
            dt = float(value) if isinstance(value, float) and 0 < value <= 3 else 2.7
            t0 = self.t
            for k in range(5):  # the finger went on while the engine stood still
                self.t = t0 + dt * k / 5
                self.push(src, x, y, ld, self.t if k % 2 else None)
            self.t = t0 + dt
            self.blocks(n)
        elif kind == "stamp":
            # a caller's stamp that must not extend the sample's life, then silence long
            # enough for the watchdog (60-85 ms)
            if value == "back":
                t_arr = self.last_stamp - 0.03
            elif isinstance(value, float):
                t_arr = self.t + value
            else:
                t_arr = self.t + 3.0
            self.push(src, x, y, ld, t_arr)
            self.blocks(math.ceil((0.055 + 0.005 * n) / self.e.block_period))
        elif kind == "stop":
            self.e.request_stop()
            self.stop_pending = True
            self.blocks(n, touch)
        else:
            self.blocks(n)

    def audit(self):
        d = np.concatenate(self.out)
        lim = self.e.renderer.safety.limits
        return audit_drive(d, self.rate, lim, touch_age=np.concatenate(self.age), silent=np.concatenate(self.silent))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy scalar warnings on inf/NaN positions
@settings(max_examples=EXAMPLES, deadline=None, derandomize=not SOAK, database=None, print_blob=True,
          suppress_health_check=list(HealthCheck))
@given(st.sampled_from(RATES), st.floats(0.00025, 0.004), st.integers(0, len(RENDERERS) - 1),
       st.lists(op, min_size=1, max_size=10))
@example(20000, 0.00390625, 0, [("idle", 1, 1, 0.0, 0.0, 0.0, 0.0),  # a stamp ages ago: the touch hold's due
                                 ("stamp", 1, 1, 0.0, 0.0, 0.0, -8.98846567431158e+304)])  # sample overflowed
def test_whole_engine_keeps_every_safety_limit(rate, block, first, ops):
    h = Harness(rate, block, first)
    for o in ops:
        h.step(*o)
    a = h.audit()
    assert a["violations"] == 0, (a, h.e.status()["output_safety"])
    assert h.e.counters["errors"] == 0
