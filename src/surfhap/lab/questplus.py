"""QUEST+ (Watson 2017, J. Vision 17(3):10): a Bayesian adaptive method over a parameter grid.

The state is a posterior (m,) over ``m`` parameter vectors. Each trial presents the stimulus,
among ``s`` candidates, that minimises the expected entropy (bits) of the posterior after the
response; the response then multiplies the posterior by its likelihood. The model is the
likelihood table ``L`` (s, m, r): the probability of outcome ``r`` (0 .. r-1) given stimulus and
parameters, so any psychometric model fits (:meth:`QuestPlus.psychometric` builds the usual one).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, PositiveInt

from surfhap.checked import Checked
from surfhap.errors import ConfigError
from surfhap.lab.psychometric import Shape, psychometric

__all__ = ["QuestPlus", "QuestPlusParams", "QuestStair"]


def _entropy(p: np.ndarray) -> np.ndarray:
    """Entropy in bits along the last axis (0 log 0 = 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return -np.sum(np.where(p > 0, p * np.log2(p), 0.0), axis=-1)


class QuestPlus:
    """QUEST+ over ``stimuli`` (s,), ``params`` (m, p) and ``likelihoods`` (s, m, r) (module
    docstring), with a ``prior`` (m,) (uniform if None). Read :meth:`next_stimulus`, present it,
    call :meth:`update` with the outcome index; :attr:`posterior` (m,) and :meth:`mean` report."""

    def __init__(self, stimuli, params, likelihoods, prior=None):
        self.stimuli = np.asarray(stimuli, dtype=float)
        self.params = np.asarray(params, dtype=float).reshape(len(params), -1)
        self.likelihoods = np.asarray(likelihoods, dtype=float)
        s, m = self.stimuli.size, self.params.shape[0]
        if self.stimuli.ndim != 1 or s == 0:
            raise ConfigError("must be a non-empty 1-D array", field="stimuli")
        lk = self.likelihoods
        if lk.ndim != 3 or lk.shape[:2] != (s, m):
            raise ConfigError(f"shape {lk.shape} is not (stimuli {s}, params {m}, outcomes)", field="likelihoods")
        if np.any(lk < 0) or not np.allclose(lk.sum(axis=2), 1.0):
            raise ConfigError("must be probabilities summing to 1 over the outcomes", field="likelihoods")
        prior = np.ones(m) if prior is None else np.asarray(prior, dtype=float)
        if prior.shape != (m,) or np.any(prior < 0) or prior.sum() <= 0:
            raise ConfigError(f"must be {m} non-negative weights, not all zero", field="prior")
        self.posterior = prior / prior.sum()

    @classmethod
    def psychometric(cls, stimuli, thresholds, slopes, lapses=(0.0,), guess: float = 0.5,
                     shape: Shape = "logistic", prior=None) -> QuestPlus:
        """QUEST+ over the grid ``thresholds`` x ``slopes`` x ``lapses`` (params columns in that
        order) of :func:`surfhap.lab.psychometric.psychometric`; outcome 1 = correct, 0 = wrong."""
        grid = np.array(np.meshgrid(thresholds, slopes, lapses, indexing="ij")).reshape(3, -1).T
        x = np.asarray(stimuli, dtype=float)[:, None]
        p = psychometric(x, grid[:, 0], grid[:, 1], guess, grid[:, 2], shape)
        return cls(stimuli, grid, np.stack([1.0 - p, p], axis=2), prior)

    def expected_entropies(self) -> np.ndarray:
        """(s,) the expected posterior entropy (bits) after presenting each stimulus."""
        joint = self.likelihoods * self.posterior[None, :, None]  # (s, m, r)
        p_outcome = joint.sum(axis=1)  # (s, r)
        with np.errstate(divide="ignore", invalid="ignore"):
            post = np.where(p_outcome[:, None, :] > 0, joint / p_outcome[:, None, :], 0.0)
        return np.sum(p_outcome * _entropy(np.moveaxis(post, 1, 2)), axis=1)

    def next_stimulus(self) -> float:
        """The stimulus of least expected entropy (the first on ties)."""
        return float(self.stimuli[int(np.argmin(self.expected_entropies()))])

    def update(self, stimulus: float, outcome: int) -> None:
        """Multiply the posterior by the likelihood of ``outcome`` at ``stimulus`` (one of :attr:`stimuli`)."""
        hit = np.flatnonzero(np.isclose(self.stimuli, stimulus, rtol=1e-9, atol=1e-12))
        if hit.size == 0:
            raise ConfigError(f"{stimulus} is not one of the stimuli", field="stimulus")
        if not 0 <= outcome < self.likelihoods.shape[2]:
            raise ConfigError(f"{outcome} is not an outcome index 0..{self.likelihoods.shape[2] - 1}", field="outcome")
        post = self.posterior * self.likelihoods[hit[0], :, outcome]
        if post.sum() <= 0:
            raise ConfigError("this outcome is impossible under every parameter vector", field="outcome")
        self.posterior = post / post.sum()

    def entropy(self) -> float:
        """The posterior entropy in bits."""
        return float(_entropy(self.posterior))

    def mean(self) -> np.ndarray:
        """(p,) the posterior mean of the parameters."""
        return self.posterior @ self.params

    def interval(self, column: int = 0, mass: float = 0.95) -> tuple[float, float]:
        """The central ``mass`` credible interval of parameter ``column`` (its marginal posterior's
        cumulative sum, interpolated linearly between grid values)."""
        vals, inv = np.unique(self.params[:, column], return_inverse=True)
        cdf = np.cumsum(np.bincount(inv, weights=self.posterior))
        return tuple(float(np.interp(q, cdf, vals)) for q in ((1 - mass) / 2, (1 + mass) / 2))

    def mode(self) -> np.ndarray:
        """(p,) the parameter vector of greatest posterior probability."""
        return self.params[int(np.argmax(self.posterior))]


class QuestPlusParams(Checked):
    """The design file's QUEST+ choice (:class:`QuestStair`): ``max_trials`` and a fixed ``lapse``
    (1 %: the comfort model's, :data:`surfhap.lab.comfort.COMFORT_LAPSE`)."""

    method: Literal["questplus"] = "questplus"
    max_trials: PositiveInt = 40
    lapse: float = Field(0.01, ge=0.0, lt=0.5)


class QuestStair:
    """QUEST+ with the staircase's interface (:attr:`level`, :meth:`update` with a "positive"
    response, :attr:`finished`, :meth:`result`), for yes/no answers: P(positive | x) is the
    ``shape`` function of ``levels`` over thresholds = ``levels`` x ``slopes``, no guess, a fixed
    ``lapse``; ``max_trials`` trials. The result's ``threshold`` is the level where the
    posterior-mean function of the posterior-mean parameters reaches ``target``
    (0.5: the threshold parameter)."""

    def __init__(self, levels, slopes, max_trials: int, target: float = 0.5, lapse: float = 0.01):
        self.q = QuestPlus.psychometric(levels, levels, slopes, (lapse,), guess=0.0)
        self.max_trials, self.target, self.lapse = max_trials, target, lapse
        self._levels: list[float] = []
        self._responses: list[bool] = []
        self.level = self.q.next_stimulus()

    @property
    def finished(self) -> bool:
        return len(self._levels) >= self.max_trials

    def update(self, positive: bool) -> None:
        if self.finished:
            raise ConfigError("the QUEST+ run has finished", field="questplus")
        self.q.update(self.level, int(bool(positive)))
        self._levels.append(self.level)
        self._responses.append(bool(positive))
        self.level = self.q.next_stimulus()

    def result(self):
        """A :class:`~surfhap.lab.staircase.StaircaseResult` (no reversals) with the posterior estimate."""
        from surfhap.lab.staircase import StaircaseResult

        thr, slope, _ = self.q.mean()
        f = self.target / (1.0 - self.lapse)  # logistic: invert target = (1 - lapse) F
        est = float(thr + np.log(f / (1.0 - f)) / slope) if self._levels else None
        empty = np.zeros(0)
        return StaircaseResult(np.array(self._levels), np.array(self._responses, dtype=bool), empty.astype(int),
                               empty, est, "trials" if self.finished else "running")
