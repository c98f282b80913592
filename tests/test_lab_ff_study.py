"""Paper 004's study (KinesTouch sliding comparisons) run end to end on the simulated
force-feedback device: every trial's two effects play on the one FF loop (FFLoop + FFEngine,
the safety stage last) that 'ff simulate' / 'ff run' use, switched per stimulus while the loop
runs on; the simulated participant strokes each for the protocol's 3.5 s.

The reference for "the effect played" is the paper's definition of the stimuli (004 Sec. 3.5,
5.2), not the code: FOLLOW moves the screen with the finger, REVERSE against it, STATIC keeps
it still."""

from __future__ import annotations

import json
from datetime import date

import numpy as np

from surfhap.cli import main
from surfhap.cli._signals import StopSignals
from surfhap.cli.study import _simulate
from surfhap.ff.params import DeviceParams
from surfhap.lab.analyze_study import load_trials
from surfhap.lab.designs import build_study, template
from surfhap.lab.export import trial_table
from surfhap.lab.session import SessionRunner
from surfhap.lab.stimuli import FFStimulusPlayer, FFStudySession
from surfhap.lab.triallog import read_log

LIMIT_S = 3.5  # 004 Sec. 5.2: "each stimuli lasted 3.5 seconds from the moment the screen was touched"


def _study(tmp_path, repetitions=1):
    """The built-in 004 design (one participant, one repetition of each ordered pair per block
    to keep the simulated time short: 4 blocks x 6 pairs + 2 x 2 practice trials)."""
    d = template("kinestouch-sliding", seed=5, participants=1)
    d = d.model_validate({**d.model_dump(), "params": {"repetitions": repetitions}})
    folder = tmp_path / "s004"
    folder.mkdir()
    (folder / "study.json").write_text(json.dumps(build_study(d).model_dump(mode="json")))
    (folder / "logs").mkdir()
    return folder


def test_004_protocol_options_of_the_built_in_design():
    d = template("kinestouch-sliding")
    assert d.session.stimulus_limit_s == LIMIT_S and d.session.blank_until_release
    plan = build_study(d).participants[0]
    practice = [t for t in plan.trials if t.practice]
    # two practice trials at the start of each of the two sessions (2 blocks each), 004 Sec. 5.2
    assert len(practice) == 4 and len(plan.trials) == 240 + 4
    starts = [k for k, t in enumerate(plan.trials) if t.practice]
    first_of_session = [next(k for k, t in enumerate(plan.trials) if t.block == b) for b in (0, 2)]
    assert starts == [first_of_session[0], first_of_session[0] + 1, first_of_session[1], first_of_session[1] + 1]


def test_004_study_runs_end_to_end_on_the_simulated_ff_device(tmp_path):
    folder = _study(tmp_path)
    ff = FFStimulusPlayer(FFStudySession(simulated=True), limit_s=LIMIT_S)
    ff.session.start()
    try:
        for day in (1, 2):  # 004's two sessions, on two days
            runner = SessionRunner(folder, "P01", mode="simulated", today=date(2026, 11, day))
            assert runner.limit_s == LIMIT_S and runner.study_session == day
            try:
                _simulate(runner, 3, 0.8, 0.0, StopSignals(), ff)
            finally:
                runner.close()
    finally:
        ff.session.stop()
    assert not runner.later
    plan = runner.plan.trials
    log = read_log(folder / "logs" / "P01.jsonl")
    assert [t["trial_id"] for t in log.trials] == [t.id for t in plan]
    assert [bool(t.get("practice")) for t in log.trials] == [t.practice for t in plan]
    _, recs, incomplete, _ = load_trials(folder)  # practice trials are not analysed
    assert len(recs) == 24 and not incomplete
    exported = trial_table([log])  # ... and the export marks them
    assert exported["practice"].tolist() == [t.practice for t in plan]

    # one device record per stimulus, in the trials' order, each the trial's own effect
    played = ff.force_log
    assert [r["effect"] for r in played] == [s.render["effect"] for t in plan for s in t.stimuli]
    # the loop never stopped between stimuli: one tick every millisecond over the whole session
    t = np.concatenate([r["t"] for r in played])
    assert np.allclose(np.diff(t), 1e-3, atol=1e-9)
    # the forces at the device stay within the safety stage's limits (magnitude and slew)
    dev = DeviceParams()
    f = np.concatenate([r["force"] for r in played])
    assert np.all(np.abs(f) <= np.asarray(dev.f_max) + 1e-9)
    assert np.all(np.abs(np.diff(f, axis=0)) <= dev.slew * 1e-3 + 1e-9)
    assert ff.session.engine.error is None and ff.session.loop.error is None

    for r in played:
        on = np.flatnonzero(r["mask"])
        # lateral screen velocity against the finger's while the effect plays
        vs = np.gradient(r["screen"][:, 0], r["t"])
        if r["effect"] == "static":
            assert on.size == 0 and np.ptp(r["screen"][:, 0]) < 1e-3  # the tablet stays still
            continue
        k = slice(on[0] + 100, on[-1])
        corr = np.corrcoef(vs[k], r["finger_v"][k])[0, 1]
        # FOLLOW: the screen moves with the finger; REVERSE: against it (004 Sec. 3.5, Fig. 4)
        assert corr > 0.8 if r["effect"] == "follow" else corr < -0.8, (r["effect"], corr)
        # the stimulus lasts 3.5 s from the first touch (a 60 Hz touch report late at most)
        assert LIMIT_S - 0.1 <= r["t"][on[-1]] - r["t"][on[0]] <= LIMIT_S + 1 / 60 + 0.01
        assert not r["mask"][on[-1] + 1:].any()


def test_an_unknown_ff_device_is_one_line_exit_2(tmp_path, capsys):
    folder = _study(tmp_path)
    assert main(["study", "run", str(folder), "-p", "P01", "--simulate", "1", "--ff-device", "falcon"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--ff-device" in err[0]
    assert main(["study", "run", str(folder), "-p", "P01", "--ff-device", "sim", "--output", "sim"]) == 2
    assert "--ff-device" in capsys.readouterr().err
    assert not (folder / "logs" / "P01.jsonl").exists()  # nothing started, nothing logged
