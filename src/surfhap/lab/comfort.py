"""Comfort threshold of a participant with a staircase (Zhao et al. Sec. 2: the drive is kept
under the user's threshold by a staircase), run on the study page before the study.

The stimulus is Zhao et al.'s baseline: a constant-amplitude square wave (100 Hz, inside their
30-300 Hz range) whose amplitude is the staircase level in volts, on the study's first
material. The question is "Is this comfortable?"; "no" (uncomfortable) is the positive
response that lowers the level.

Rule (Levitt 1971, transformed up-down): *down* one step after one "uncomfortable", *up* one
step only after three "comfortable" in a row. The level is stationary where
P(comfortable)^3 = 1/2, i.e. P(uncomfortable) = 1 - 0.5^(1/3) = 20.6 % (a 1-up/1-down rule would
settle where it is uncomfortable half of the time). The staircase's estimate is the geometric
mean of the last reversals; the participant's **comfort voltage** (the ceiling ``study run``
uses as the session's safety limit) sits one final step (2 dB, x 0.794) below that estimate
(:func:`comfort_ceiling`), never above the 250 V safety limit.

No reversal (e.g. "uncomfortable" all the way down to the 5 V floor, or "comfortable" up to the
250 V limit) gives no threshold: the result records ``comfort_voltage: null`` and ``study run``
refuses to start (:func:`required_comfort_voltage`), as it does while a staircase is unfinished.

The method is the design file's ``adaptive`` field (:data:`surfhap.lab.schema.Adaptive`), or
``study comfort --method``, which overrides it with that method's defaults here
(:func:`comfort_method`):

* ``questplus`` runs QUEST+ (Watson 2017, :class:`~surfhap.lab.questplus.QuestStair`): 40 trials
  on 1 dB-spaced levels 5-250 V, a logistic P(uncomfortable) with a 1 % lapse; its estimate is
  the 20.6 % point of the function at the posterior-mean parameters;
* ``quest`` runs QUEST (Watson & Pelli 1983, :class:`~surfhap.lab.quest.Quest`) on log10 V:
  a yes/no task (gamma = 0), T at P(uncomfortable) = 20.6 %, the prior centred on the start
  level with QuestDemo's generous SD of 2 log units, 40 trials within 5-250 V; the estimate is
  the posterior mean (King-Smith et al. 1994).

For both the comfort voltage is again one 2 dB step below the estimate. ``study analyze`` estimates the
50 % point with its credible interval from either method's trials (:func:`comfort_estimate`).

The answers go to their own append-only log ``logs/<P>-comfort.jsonl``; a killed run resumes
by replaying the logged answers into the staircase (it is deterministic). The result is written
to ``logs/<P>-comfort.json``.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field

from surfhap.checked import Checked
from surfhap.errors import StudyFormatError
from surfhap.lab.quest import Quest, QuestParams
from surfhap.lab.questplus import QuestPlus, QuestPlusParams, QuestStair
from surfhap.lab.schema import Adaptive, load_study
from surfhap.lab.session import SAFETY_V_MAX
from surfhap.lab.staircase import Staircase, StaircaseParams
from surfhap.lab.triallog import TrialLog, now_iso

__all__ = ["ComfortRunner", "ComfortOptions", "comfort_method", "comfort_estimate", "default_comfort_params", "comfort_voltage_of", "read_comfort", "required_comfort_voltage",
           "comfort_ceiling", "COMFORT_FREQUENCY", "COMFORT_TARGET"]

COMFORT_FREQUENCY = 100.0  # Hz, inside Zhao et al.'s 30-300 Hz baseline range (design choice)


# P(uncomfortable) at which the default staircase settles: up after 3 "comfortable" (negatives),
# down after 1 "uncomfortable" (positive): (1 - p)^3 = 1/2
COMFORT_TARGET = 1.0 - 0.5 ** (1.0 / 3.0)
QUEST_TRIALS = 40
COMFORT_LAPSE = 0.01  # P(uncomfortable) tops out at 99 % in QUEST+'s model and in the analysis fit
_NAMES = {"quest": "QUEST (Watson & Pelli 1983)", "questplus": "QUEST+ (Watson 2017)"}


class ComfortOptions(Checked):
    """method: "staircase" (:func:`default_comfort_params`), "quest" or "questplus" (module
    docstring), None: the design's ``adaptive`` choice; start: the first level (V)."""

    method: Literal["staircase", "quest", "questplus"] | None = None
    start: float = Field(default=60.0, ge=5.0, le=SAFETY_V_MAX)


def comfort_method(design: Adaptive | None, options: ComfortOptions) -> Adaptive:
    """The comfort run's method: ``options.method``'s defaults (module docstring) when it is given
    and differs from the design's choice, else the design's ``adaptive`` (default: the
    staircase); the levels capped at the 250 V safety limit (a ConfigError naming the field if
    the start lies above it)."""
    name = options.method or (design.method if design is not None else "staircase")
    if design is None or design.method != name:
        design = (default_comfort_params(options.start) if name == "staircase" else
                  QuestPlusParams(max_trials=QUEST_TRIALS, lapse=COMFORT_LAPSE) if name == "questplus" else
                  QuestParams(prior_mean=np.log10(options.start), prior_sd=2.0, gamma=0.0, p_threshold=COMFORT_TARGET,
                              max_trials=QUEST_TRIALS, min_level=np.log10(5.0), max_level=np.log10(SAFETY_V_MAX)))
    if isinstance(design, QuestPlusParams):
        return design
    cap = np.log10(SAFETY_V_MAX) if isinstance(design, QuestParams) and design.scale == "log10" else SAFETY_V_MAX
    return type(design)(**{**design.model_dump(), "max_level": float(min(design.max_level, cap))})


def default_comfort_params(start: float = 60.0) -> StaircaseParams:
    """Up after 3 "comfortable" in a row, down after 1 "uncomfortable" (target: 20.6 %
    uncomfortable, :data:`COMFORT_TARGET`), in dB steps (4 dB, then 2 dB after two reversals),
    from ``start`` V, 8 reversals or 60 trials, threshold = geometric mean of the last 6
    reversals, levels within 5 V .. 250 V (design choices: the paper names the method only;
    on simulated participants a run takes ~30 trials)."""
    return StaircaseParams(start=start, steps=(4.0, 4.0, 2.0), up=3, down=1, step_type="db", max_trials=60,
                           max_reversals=8, average_last=6, min_level=5.0, max_level=SAFETY_V_MAX)


def comfort_ceiling(threshold: float | None, params: StaircaseParams) -> float | None:
    """The comfort voltage for a staircase estimate ``threshold`` (V): one final step below it
    (dB staircase: x 10^(-step/20); linear: - step), within the staircase's level range; None
    without a threshold."""
    if threshold is None:
        return None
    step = params.steps[-1]
    v = threshold * 10.0 ** (-step / 20.0) if params.step_type == "db" else threshold - step
    return float(min(max(v, params.min_level), params.max_level))


def comfort_estimate(records: list[dict]) -> dict:
    """The 50 % discomfort voltage from a comfort run's trial ``records`` (``level_V``, ``answer``),
    whichever method placed them: ``value`` and ``ci`` are the posterior mean and central 95 %
    credible interval of the threshold under QUEST+'s model (logistic P(uncomfortable), 1 % lapse,
    flat prior over 5-250 V x slopes 0.01-1 /V); ``ml_value`` is the maximum-likelihood fit's
    threshold (:func:`~surfhap.lab.psychometric.fit_psychometric`, same model). ConfigError with
    fewer than two levels."""
    from surfhap.lab.psychometric import fit_psychometric

    v = np.round([float(r["level_V"]) for r in records], 6)
    levels, idx = np.unique(v, return_inverse=True)
    no = np.array([r["answer"] == "no" for r in records])
    ml = fit_psychometric(levels, np.bincount(idx, minlength=levels.size), np.bincount(idx, no, levels.size),
                          lapse=COMFORT_LAPSE)
    q = QuestPlus.psychometric(levels, np.geomspace(5.0, SAFETY_V_MAX, 141), np.geomspace(0.01, 1.0, 21),
                               (COMFORT_LAPSE,), guess=0.0)
    for x, n in zip(v, no):
        q.update(x, int(n))
    return {"value": float(q.mean()[0]), "ci": q.interval(0), "ml_value": ml.threshold, "n": len(records)}


def read_comfort(path: Path) -> dict:
    """A comfort result (``logs/<P>-comfort.json``, written by :class:`ComfortRunner`) with
    ``comfort_voltage`` a float or None; StudyFormatError when it is not one."""
    try:
        d = json.loads(path.read_text())
        d["comfort_voltage"] = None if d["comfort_voltage"] is None else float(d["comfort_voltage"])
    except (ValueError, KeyError, TypeError):
        raise StudyFormatError("not a comfort result", source=str(path), field="comfort_voltage") from None
    return d


def comfort_voltage_of(study_dir: str | Path, participant: str) -> float | None:
    """The participant's comfort voltage from ``logs/<P>-comfort.json``, if measured."""
    p = Path(study_dir) / "logs" / f"{participant}-comfort.json"
    return read_comfort(p)["comfort_voltage"] if p.is_file() else None


def required_comfort_voltage(study_dir: str | Path, participant: str) -> float | None:
    """The comfort voltage ``study run`` must use: None when no comfort staircase was run for
    the participant (the session's limit stays the 250 V safety limit); raises
    :class:`~surfhap.errors.StudyFormatError` (one line) when one was started but gave no
    threshold (no reversal) or is unfinished: a session must not start without it."""
    folder = Path(study_dir)
    result = folder / "logs" / f"{participant}-comfort.json"
    doc = read_comfort(result) if result.is_file() else {"comfort_voltage": None}
    v = doc["comfort_voltage"]
    if v is not None and "staircase_threshold_V" not in doc:
        # written by surfhap before 3-up/1-down: its voltage was judged uncomfortable half the time
        raise StudyFormatError("measured with the old 1-up/1-down comfort rule (uncomfortable half the time); run "
                               "'study comfort' again or give --comfort-voltage", source=str(result),
                               field="staircase_threshold_V")
    if v is None and result.is_file():
        raise StudyFormatError("the comfort staircase found no threshold (no reversal); run 'study comfort' again "
                               "or give --comfort-voltage", source=str(result), field="comfort_voltage")
    if v is None and (folder / "logs" / f"{participant}-comfort.jsonl").is_file():
        raise StudyFormatError("the comfort staircase is unfinished; finish it with 'study comfort' or give "
                               "--comfort-voltage", source=str(folder / "logs" / f"{participant}-comfort.jsonl"),
                               field="comfort_voltage")
    return v


class ComfortRunner:
    """Page-compatible runner (``state`` / ``stimulus`` / ``answer`` / ``resume``) of the
    comfort staircase of one participant."""

    limit_s = None  # the square wave plays while touched: no stimulus time limit
    v_max = SAFETY_V_MAX

    def __init__(self, study_dir: str | Path, participant: str, params: Adaptive | None = None,
                 material: str | None = None, options: ComfortOptions | None = None):
        self.dir = Path(study_dir)
        study = load_study(self.dir)
        self.plan = study.participant(participant)
        self.options = options or ComfortOptions()
        self.adaptive = params or comfort_method(study.design.adaptive, self.options)
        self.params = self.adaptive if isinstance(self.adaptive, StaircaseParams) else default_comfort_params()
        self.material = material or next((str(s.render["material"]) for t in self.plan.trials for s in t.stimuli
                                          if "material" in s.render), "cork")
        self.log = TrialLog(self.dir / "logs" / f"{self.plan.id}-comfort.jsonl", participant=self.plan.id,
                            config={"participant": self.plan.id, "procedure": "comfort staircase",
                                    "method": self.adaptive.method,
                                    "adaptive": self.adaptive.model_dump(mode="json"),
                                    "material": self.material, "square_frequency": COMFORT_FREQUENCY})
        a = self.adaptive
        self.stair = (QuestStair(np.geomspace(5.0, SAFETY_V_MAX, 35), np.geomspace(0.01, 1.0, 9), a.max_trials,
                                 COMFORT_TARGET, a.lapse) if isinstance(a, QuestPlusParams) else
                      Quest(a) if isinstance(a, QuestParams) else Staircase(a))
        for rec in self.log.contents.trials:  # replay a killed run
            self.stair.update(rec["answer"] == "no")
        self.gain = 1.0
        self.last_record = None
        self._lock = threading.Lock()
        self.total = a.max_trials

    @property
    def n_done(self) -> int:
        return len(self.stair.result().levels)

    @property
    def finished(self) -> bool:
        return self.stair.finished

    def _tid(self) -> str:
        return f"{self.plan.id}-comfort-{self.n_done:03d}"

    def state(self) -> dict:
        with self._lock:
            base = {"done": self.n_done, "total": self.total, "participant": self.plan.id}
            if self.finished:
                return {**base, "status": "done"}
            return {**base, "status": "trial", "block_label": "comfort",
                    "trial": {"id": self._tid(), "prompt": "Touch and slide. Is this comfortable?",
                              "response": "choice", "stimuli": ["touch"], "real": [None],
                              "choices": [{"id": "yes", "label": "yes, comfortable"},
                                          {"id": "no", "label": "no, uncomfortable"}], "toggles": []}}

    def resume(self) -> None:
        return None

    def stimulus(self, trial_id: str, index: int):
        from surfhap.lab.schema import Stimulus

        with self._lock:
            if self.finished or trial_id != self._tid() or index != 0:
                return None
            return Stimulus(label="touch", render={"material": self.material, "method": "square",
                                                   "square_frequency": COMFORT_FREQUENCY,
                                                   "square_amplitude": round(self.stair.level, 3)})

    def answer(self, trial_id: str, answer: str, rt_client_s: float | None = None) -> dict:
        with self._lock:
            accepted = False
            if not self.finished and trial_id == self._tid():
                if answer not in ("yes", "no"):
                    raise StudyFormatError(f"answer {answer!r} is not yes or no", field="answer")
                rec = {"trial_id": trial_id, "index": self.n_done, "level_V": self.stair.level, "answer": answer,
                       "rt_s": None if rt_client_s is None else round(float(rt_client_s), 4),
                       "answered_at": now_iso()}
                accepted = self.log.append_trial(rec)
                self.last_record = {**rec, "is_correct": None}
                self.stair.update(answer == "no")
                if self.finished:
                    self._finish()
        return {**self.state(), "accepted": accepted}

    def _finish(self) -> None:
        res = self.stair.result()
        self.log.event("end", threshold_V=res.threshold, stopped_by=res.stopped_by)
        p = self.params
        out = {"participant": self.plan.id, "comfort_voltage": comfort_ceiling(res.threshold, p),
               "staircase_threshold_V": res.threshold, "stopped_by": res.stopped_by,
               "reversal_levels_V": res.reversal_levels.tolist(), "levels_V": res.levels.tolist(),
               "adaptive": self.adaptive.model_dump(mode="json"),
               **({"quest_sd_log10": self.stair.sd()} if isinstance(self.stair, Quest) else {}),
               "method": f"{_NAMES.get(self.adaptive.method, f'{p.up}-up/{p.down}-down staircase')} on a constant-amplitude square wave (Zhao et al. "
                         f"Sec. 2-3); comfort voltage one {p.steps[-1]:g} {'dB' if p.step_type == 'db' else 'V'} "
                         "step below the estimate",
               "finished_at": now_iso()}
        (self.dir / "logs" / f"{self.plan.id}-comfort.json").write_text(json.dumps(out, indent=1) + "\n")

    def result(self):
        return self.stair.result()

    def close(self) -> None:
        self.log.close()
