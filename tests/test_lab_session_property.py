"""Whole-process property test of the study runner (issue 17): hypothesis drives what
``surfhap study run --output ...`` runs, through the entry points the page server calls.

* :class:`~surfhap.lab.session.SessionRunner`: ``state``, ``stimulus`` (any index, stale or
  bogus trial ids), ``answer`` (valid, invalid, repeated, for another trial), ``resume``,
  and a restart (the process killed and run again: a new runner on the same log);
* :class:`~surfhap.lab.stimuli.StimulusPlayer` on a :class:`~surfhap.live.session.LiveSession`
  built as ``study run`` builds it (the first material's chain at the 250 V default, muted):
  ``select`` of the trial's stimuli and of adversarial render specs (a square wave of 400 V,
  an unknown material that raises, a muted real sample), ``touch`` with any position and
  pressure and page time stamps that go backwards, jump to the future, are NaN or infinite,
  ``lift``, ``mute``;
* the renderer raising inside the engine for a few blocks, real stalls (the output thread
  not called for 20-120 ms, with and without a finger moving meanwhile), and a stop;
* the engine's ``render`` as the output backend calls it, on the engine clock.

Every emitted sample is audited independently (:func:`surfhap.live.audit.audit_drive`)
against the session's limits: ``|V|`` within the comfort ceiling (``--comfort-voltage``,
which the 250 V chain of the session must respect too), the rise limit, the watchdog (0 V
when the freshest touch is older than 55 ms at the sample's emission), silence after the
stop ramp. Trials are never lost: the log holds exactly the accepted answers, in order, after
any restart, and the runner continues with the first trial not logged.

CI runs ``SURFHAP_STUDY_EXAMPLES`` sequences (default 200: the stalls are real sleeps);
``make soak`` (``SURFHAP_SAFETY_SOAK=1``, ``SURFHAP_SAFETY_EXAMPLES``) runs a hundredth of
the engine's soak count here, with fresh random seeds.
"""

from __future__ import annotations

import functools
import json
import math
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from surfhap.errors import ConfigError
from surfhap.lab.designs import build_study
from surfhap.lab.schema import DesignSpec
from surfhap.lab.session import SessionRunner
from surfhap.lab.stimuli import StimulusPlayer
from surfhap.lab.triallog import read_log
from surfhap.live.audit import audit_drive
from surfhap.runtime.clock import now
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.live.session import LiveSession
from surfhap.render.safety import SafetyLimits

SOAK = os.environ.get("SURFHAP_SAFETY_SOAK", "") not in ("", "0")
EXAMPLES = int(os.environ.get("SURFHAP_STUDY_EXAMPLES")
               or (int(os.environ["SURFHAP_SAFETY_EXAMPLES"]) // 100 if SOAK and "SURFHAP_SAFETY_EXAMPLES" in os.environ
                   else 200))
RATE = 20000
STOP_RAMP = 0.010
MATERIALS = ["cork", "denim"]
# render specs a page could ask for beyond the trial's own (each goes through player.select)
EXTRA_SPECS = ({"material": "cork", "method": "square", "square_amplitude": 400.0},
               {"material": "no-such-material"}, {"real": "cork"}, {"material": "denim", "method": "zhao"})
COMFORT = (250.0, 120.0, 30.0)  # the session's ceiling: the design's 250 V, or a participant's comfort voltage


@functools.lru_cache(maxsize=1)
def study_json() -> str:
    spec = DesignSpec.model_validate({"format": "surfhap-study-design", "version": 1, "kind": "identification",
                                      "name": "property", "participants": 1, "seed": 5,
                                      "params": {"materials": MATERIALS, "repetitions": 2}})
    return json.dumps(build_study(spec).model_dump(mode="json"))


class Harness:
    def __init__(self, folder: Path, comfort: float, gain: float):
        from surfhap.exchange.materials import load_material
        from surfhap.render.chain import ChainConfig, TextureChain

        if folder.exists():
            shutil.rmtree(folder)
        (folder / "logs").mkdir(parents=True)
        (folder / "study.json").write_text(study_json())
        self.folder = folder
        self.comfort, self.gain = comfort, gain
        self.runner = SessionRunner(folder, "P01", gain=gain, comfort_voltage=comfort, mode="page")
        self.accepted: list[str] = []
        # as 'study run --output': build_session's chain of the first material at the default limits
        first = TextureChain(load_material(MATERIALS[0]), ChainConfig(drive_rate=RATE))
        self.engine = LiveEngine(first, EngineConfig(block_seconds=0.001, stop_ramp=STOP_RAMP, trace_capacity=64,
                                                     latency_capacity=64, touch_capacity=256))
        self.session = LiveSession(self.engine, backend=None)
        self.player = StimulusPlayer(self.session, gain=self.runner.gain, v_max=self.runner.v_max)
        self.player.mute()
        self.t_page = 1000.0  # ms, the page's clock
        self.x = 0.3
        self.fresh = -math.inf  # engine-clock time of the newest touch handed over (taken after the push)
        self.out, self.age, self.silent = [], [], []
        self.silent_from = None
        self.stop_pending = False
        self.n = 0
        self.faults = 0
        self.select_errors = 0

    # ------------------------------------------------------------------ output side
    def blocks(self, n: int, touch=None) -> None:
        e = self.engine
        idx = np.arange(e.block_frames)
        for _ in range(n):
            if touch is not None:
                self.touch(*touch)
            if self.stop_pending and self.silent_from is None:
                self.silent_from = self.n + math.ceil(STOP_RAMP * RATE - 1e-9)
            t = now()
            v = e.render(e.block_frames, t).copy()
            self.out.append(v)
            self.age.append(t + idx / RATE - self.fresh)
            g = self.n + idx
            self.silent.append(g >= self.silent_from if self.silent_from is not None else np.zeros(v.size, bool))
            self.n += v.size

    def touch(self, x, y, p, t_kind) -> None:
        self.x = (self.x + 0.004) % 1.0
        self.t_page += 4.0
        t_ms = {"ok": self.t_page, "back": self.t_page - 5000.0, "future": self.t_page + 1e9, "nan": math.nan,
                "inf": math.inf, "-inf": -math.inf, "zero": 0.0}[t_kind]
        self.player.touch(1, self.x + x if math.isfinite(x) else x, y, p, t_ms, 800.0, 400.0)
        self.fresh = now()

    def lift(self, t_kind) -> None:
        self.player.lift(1, {"ok": self.t_page, "nan": math.nan, "inf": math.inf}.get(t_kind, 0.0))
        self.fresh = now()

    # ------------------------------------------------------------------ page side
    def step(self, kind, n, x, y, p, t_kind, value) -> None:
        r = self.runner
        if kind == "touch":
            self.blocks(n, (x, y, p, t_kind))
        elif kind == "stimulus":  # POST /api/stimulus
            cur = r.current()
            tid = cur.id if cur is not None and value % 5 else "T-bogus"
            stim = r.stimulus(tid, value % 4 - 1)
            if stim is not None:
                self.select(stim.render)
            self.blocks(n, (x, y, p, t_kind))
        elif kind == "select":  # a spec the trial does not hold
            self.select(EXTRA_SPECS[value % len(EXTRA_SPECS)])
            self.blocks(n, (x, y, p, t_kind))
        elif kind == "answer":  # POST /api/answer
            cur = r.current()
            if cur is None:
                tid, ans = "T-bogus", "x"
            else:
                ids = [c.id for c in cur.choices]
                tid = cur.id if value % 4 else (r.plan.trials[0].id)
                ans = ids[value % len(ids)] if value % 3 else "not-a-choice"
            try:
                res = r.answer(tid, ans, rt_client_s=float(value))
            except ConfigError:
                res = None  # 400, nothing written
            else:
                self.player.mute()
                if res["accepted"]:
                    self.accepted.append(tid)
            self.blocks(n)
        elif kind == "resume":
            r.resume()
            self.blocks(n, (x, y, p, t_kind))
        elif kind == "lift":
            self.lift(t_kind)
            self.blocks(n)
        elif kind == "fault":  # the renderer raises inside the engine for a few blocks
            self.raise_for(value % 4 + 1)
            self.blocks(n, (x, y, p, t_kind))
        elif kind == "stall":  # the output thread is not called; the finger may move meanwhile
            secs = (0.02, 0.06, 0.12)[value % 3]
            if value % 2:
                self.touch(x, y, p, t_kind)
            time.sleep(secs)
            self.blocks(n)
        elif kind == "restart":  # the process is killed and run again
            r.close()
            self.runner = SessionRunner(self.folder, "P01", gain=self.gain, comfort_voltage=self.comfort, mode="page")
            self.player.mute()
            self.blocks(n)
        elif kind == "stop":
            self.engine.request_stop()
            self.stop_pending = True
            self.blocks(n, (x, y, p, t_kind))
        else:
            self.blocks(n)

    def select(self, spec) -> None:
        try:
            self.player.select(spec)
        except (ConfigError, ValueError, OSError):  # the page answers 500/400; the output goes on
            self.select_errors += 1

    def raise_for(self, k: int) -> None:
        eng = self.engine
        rend = eng.renderer
        left = [k]
        original = type(rend).process

        def process(*args, **kw):
            if left[0] > 0:
                left[0] -= 1
                self.faults += 1
                raise RuntimeError("renderer fault")
            return original(rend, *args, **kw)

        rend.process = process  # this renderer only (it is rebuilt for every example)

    def audit(self) -> dict:
        d = np.concatenate(self.out)
        lim = SafetyLimits(v_max=self.runner.v_max)
        return audit_drive(d, RATE, lim, touch_age=np.concatenate(self.age), silent=np.concatenate(self.silent))

    def check_trials(self) -> None:
        log = read_log(self.runner.log.path)
        ids = [t["trial_id"] for t in log.trials]
        assert ids == self.accepted, (ids, self.accepted)
        plan = [t.id for t in self.runner.plan.trials]
        assert ids == plan[: len(ids)]  # in order, none skipped, none twice
        assert self.runner.n_done == len(ids)
        cur = self.runner.current()
        assert (cur is None) == (len(ids) == len(plan)) and (cur is None or cur.id == plan[len(ids)])


anything = st.floats(allow_nan=True, allow_infinity=True)
coord = st.one_of(st.floats(-0.1, 1.1), st.sampled_from([0.5, 1e300, -1e300]), anything)
pressure = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1.0, 40.0, -1.0, 1e300]), anything)
t_kind = st.sampled_from(["ok"] * 6 + ["back", "future", "nan", "inf", "-inf", "zero"])
KINDS = ("touch",) * 5 + ("stimulus",) * 3 + ("select", "answer", "answer", "resume", "lift", "fault", "stall",
                                             "restart", "stop", "idle")
op = st.tuples(st.sampled_from(KINDS), st.integers(1, 12), coord, coord, pressure, t_kind, st.integers(0, 60))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy scalar warnings on inf/NaN positions
@settings(max_examples=EXAMPLES, deadline=None, derandomize=not SOAK, database=None, print_blob=True,
          suppress_health_check=list(HealthCheck))
@given(st.sampled_from(COMFORT), st.sampled_from([1.0, 4.0]), st.lists(op, min_size=1, max_size=14))
def test_study_runner_keeps_every_output_limit_and_every_trial(tmp_path_factory, comfort, gain, ops):
    h = Harness(tmp_path_factory.getbasetemp() / "study-property", comfort, gain)
    try:
        for o in ops:
            h.step(*o)
        a = h.audit()
        assert a["violations"] == 0, (a, h.engine.status()["output_safety"], h.faults)
        h.check_trials()
    finally:
        h.runner.close()


def test_the_harness_drives_and_the_audit_sees_it(tmp_path):
    """The property test is not vacuous: a touched stimulus drives (near the ceiling with the
    largest gain), and an emitted stream beyond the ceiling is counted by the audit."""
    h = Harness(tmp_path / "s", 30.0, 4.0)
    try:
        h.step("stimulus", 1, 0.0, 0.5, 0.5, "ok", 1)
        h.step("touch", 300, 0.0, 0.5, 0.5, "ok", 0)
        d = np.concatenate(h.out)
        assert np.max(np.abs(d)) > 10.0
        assert h.audit()["violations"] == 0
        h.out.append(np.full(4, 31.0))
        h.age.append(np.zeros(4))
        h.silent.append(np.zeros(4, bool))
        assert h.audit()["over_v_max"] >= 1
    finally:
        h.runner.close()
