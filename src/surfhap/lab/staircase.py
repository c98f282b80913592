"""Adaptive staircases (n-up / m-down), e.g. to keep the drive under a participant's comfort
threshold (Zhao et al. Sec. 2: "the input voltage is modulated proportionally using the
staircase method").

Rule: the level goes *down* one step after ``down`` consecutive "positive" responses (correct,
"I feel it", "too strong") and *up* one step after ``up`` consecutive negative ones. A
reversal is a change of direction. The run stops after ``max_trials`` trials or
``max_reversals`` reversals, whichever comes first (``stop="either"``), or, as PsychoPy's
``StairHandler`` (``stop="both"``), only once both counts are reached; the threshold is the mean of the last
``average_last`` reversal levels (geometric mean for a ``"db"`` staircase). An up/down
staircase converges to the level where P(positive)^down = 0.5 for up = 1 (Levitt 1971):
1-up/1-down 50 %, 1-up/2-down 70.7 %, 1-up/3-down 79.4 %; for down = 1 where
P(negative)^up = 0.5: 3-up/1-down 20.6 % positives (the comfort staircase,
:mod:`surfhap.lab.comfort`, where "uncomfortable" is the positive response).

Steps: ``steps`` is a list; step ``steps[min(r, len-1)]`` is used after ``r`` reversals (a
step rule such as (8, 4, 2) halves the step after the first reversals). ``step_type``
"linear" adds/subtracts the step (level units), "db" multiplies by 10^(+-step/20).
``initial_rule`` (PsychoPy's ``applyInitialRule``) steps after every response (1-up/1-down)
until the first reversal; ``up``/``down`` apply from then on.
The level is clamped to [min_level, max_level]; for a drive voltage, max_level is the safety
limit (250 V), so a staircase can never ask for more.

QUEST+ is :mod:`surfhap.lab.questplus` (own code: the PyPI ``questplus`` is GPL-3), QUEST
:mod:`surfhap.lab.quest`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
from pydantic import Field, FiniteFloat, PositiveFloat, model_validator

from surfhap.checked import Checked
from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable

__all__ = ["StaircaseParams", "Staircase", "StaircaseResult", "target_probability", "run_simulated"]


def target_probability(up: int, down: int) -> float:
    """P(positive) at which an ``up``-up/``down``-down staircase is stationary: the chance that
    ``down`` positives in a row come before ``up`` negatives in a row is 1/2. With q = 1 - p
    that chance is p^(d-1) (1 - q^u) / (p^(d-1) + q^(u-1) - p^(d-1) q^(u-1)) (a run race,
    Feller Ch. VIII); for up = 1 it is p^down, so p = 0.5^(1/down)."""
    from scipy.optimize import brentq

    def race(p: float) -> float:
        q = 1.0 - p
        a, b = p ** (down - 1), q ** (up - 1)
        return a * (1.0 - q ** up) / (a + b - a * b) - 0.5

    return float(brentq(race, 1e-12, 1.0 - 1e-12))


class StaircaseParams(Checked):
    """start: first level; steps: step sizes by reversal count (level units, or dB for
    ``step_type="db"``); up/down: consecutive negatives/positives to step up/down;
    max_trials / max_reversals: stop rules (``stop``: "either" reached, or "both");
    initial_rule: 1-up/1-down until the first reversal; average_last: reversals averaged for the
    threshold; min_level / max_level: clamp (max_level <= safety limit for voltages);
    method: the tag of the design file's ``adaptive`` choice (:data:`surfhap.lab.schema.Adaptive`)."""

    method: Literal["staircase"] = "staircase"
    start: FiniteFloat
    steps: tuple[PositiveFloat, ...] = Field(default=(1.0,), min_length=1)
    up: int = Field(default=1, ge=1)
    down: int = Field(default=2, ge=1)
    step_type: Literal["linear", "db"] = "linear"
    max_trials: int = Field(default=100, ge=1)
    max_reversals: int = Field(default=12, ge=1)
    average_last: int = Field(default=6, ge=1)
    stop: Literal["either", "both"] = "either"
    initial_rule: bool = False
    min_level: float = 0.0
    max_level: float = np.inf

    @model_validator(mode="after")
    def _start_within_the_clamp(self):
        if not self.min_level <= self.start <= self.max_level:
            raise ValueError(f"start must lie within [{self.min_level}, {self.max_level}]")
        if self.step_type == "db" and not self.min_level > 0:
            raise ValueError("a dB staircase needs min_level > 0")
        return self


@dataclass(frozen=True)
class StaircaseResult(Result):
    """levels (n,), responses (n,) bool, reversal_trials (r,) indices of the trials whose
    level is a reversal point, reversal_levels (r,), threshold (None if there are no
    reversals), stopped_by: "trials" | "reversals" | "trials and reversals" | "running"."""

    levels: np.ndarray
    responses: np.ndarray
    reversal_trials: np.ndarray
    reversal_levels: np.ndarray
    threshold: float | None
    stopped_by: str

    def summary(self) -> dict:
        return jsonable({"trials": self.levels.size, "reversals": self.reversal_trials.size,
                         "threshold": self.threshold, "stopped_by": self.stopped_by})

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), **asdict(self)})

    def plot(self, ax=None):
        """Levels over the trials, reversals and the threshold."""
        from surfhap.report.lab_figures import plot_staircase

        return plot_staircase(self, ax)


class Staircase:
    """An up/down staircase: read :attr:`level`, present it, call :meth:`update` with the
    response, until :attr:`finished`."""

    def __init__(self, params: StaircaseParams):
        self.params = params
        self.reset()

    def reset(self) -> None:
        self.level = float(self.params.start)
        self._levels: list[float] = []
        self._responses: list[bool] = []
        self._rev_trials: list[int] = []
        self._run = 0
        self._direction = 0  # -1 down, +1 up, 0 none yet

    @property
    def n_reversals(self) -> int:
        return len(self._rev_trials)

    @property
    def finished(self) -> bool:
        p = self.params
        done = (len(self._levels) >= p.max_trials, self.n_reversals >= p.max_reversals)
        return all(done) if p.stop == "both" else any(done)

    def _step(self, sign: int) -> None:
        p = self.params
        s = p.steps[min(self.n_reversals, len(p.steps) - 1)]
        new = self.level * 10.0 ** (sign * s / 20.0) if p.step_type == "db" else self.level + sign * s
        self.level = float(min(max(new, p.min_level), p.max_level))

    def update(self, positive: bool) -> None:
        """Record the response to the current level and move to the next level."""
        if self.finished:
            raise ConfigError("the staircase has finished", field="staircase")
        positive = bool(positive)
        # consecutive answers of this kind (a step restarts the count)
        self._run = self._run + 1 if self._responses and self._responses[-1] == positive else 1
        trial = len(self._levels)
        self._levels.append(self.level)
        self._responses.append(positive)
        p = self.params
        up, down = (1, 1) if p.initial_rule and not self._rev_trials else (p.up, p.down)
        if self._run >= (down if positive else up):
            self._run = 0
            sign = -1 if positive else +1
            if self._direction != 0 and sign != self._direction:
                self._rev_trials.append(trial)
            self._direction = sign
            self._step(sign)

    def result(self) -> StaircaseResult:
        p = self.params
        lv = np.array(self._levels, dtype=float)
        rt = np.array(self._rev_trials, dtype=int)
        rl = lv[rt] if rt.size else np.zeros(0)
        thr = None
        if rl.size:
            last = rl[-min(p.average_last, rl.size):]
            thr = float(np.exp(np.mean(np.log(last)))) if p.step_type == "db" else float(np.mean(last))
        stopped = ("running" if not self.finished else "trials and reversals" if p.stop == "both" else
                   "reversals" if self.n_reversals >= p.max_reversals else "trials")
        return StaircaseResult(lv, np.array(self._responses, dtype=bool), rt, rl, thr, stopped)


def run_simulated(params: StaircaseParams, p_positive: Callable[[float], float],
                  rng: np.random.Generator) -> StaircaseResult:
    """Run a staircase against a simulated observer whose probability of a positive response
    at level x is ``p_positive(x)``."""
    s = Staircase(params)
    while not s.finished:
        s.update(rng.random() < p_positive(s.level))
    return s.result()
