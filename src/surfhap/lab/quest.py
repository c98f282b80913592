"""QUEST (Watson & Pelli 1983, Perception & Psychophysics 33:113-120): a Bayesian adaptive
threshold method over one parameter, the threshold ``T`` in log intensity.

Model (Watson & Pelli 1983: a Weibull function of log intensity with guess and lapse rates;
as Pelli's QuestCreate writes it): the probability of a positive response (correct, "I feel it") at log intensity x is

    psi(x) = delta gamma + (1 - delta) (1 - (1 - gamma) exp(-10^(beta (x - T + eps))))

with the paper's defaults beta = 3.5 and delta = 0.01, and gamma the task's guess rate (0.5 for
2AFC, 0 for yes/no). ``eps`` places T where psi = ``p_threshold`` (closed form below; 0.82 is
the criterion of Pelli's QuestCreate/QuestDemo and of PsychoPy's ``QuestHandler``, a user
option). The prior on T is Gaussian (``prior_mean``, ``prior_sd``) on the grid
``prior_mean +- range / 2`` in steps of ``grain`` (QuestCreate's grain 0.01 and range 5); each
response multiplies the posterior by psi or 1 - psi (kept as logs, the grid allocated once).

The next trial is placed at the posterior mean (King-Smith et al. 1994, Vision Res.
34:885-912: more efficient than the mode), or at the mode (Watson & Pelli's maximum of the
posterior) or a posterior ``quantile`` (Pelli 1987, as QuestQuantile), within ``[min_level, max_level]``. The run
stops after ``max_trials`` trials or once the posterior SD is below ``sd_stop``. Presented
levels are ``10**x`` with ``scale="log10"`` (x in log10 units, e.g. log10 V) or x itself.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, FiniteFloat, PositiveFloat, PositiveInt, model_validator

from surfhap.checked import Checked
from surfhap.errors import ConfigError

__all__ = ["QuestParams", "Quest"]


class QuestParams(Checked):
    """Module docstring; every intensity (prior_mean, min/max_level) is in x units (log10 for
    ``scale="log10"``)."""

    method: Literal["quest"] = "quest"
    prior_mean: FiniteFloat
    prior_sd: PositiveFloat
    beta: PositiveFloat = 3.5  # Watson & Pelli 1983
    delta: float = Field(0.01, ge=0.0, lt=1.0)  # Watson & Pelli 1983
    gamma: float = Field(0.5, ge=0.0, lt=1.0)  # the task's guess rate: 0.5 for 2AFC
    p_threshold: float = Field(0.82, gt=0.0, lt=1.0)
    grain: PositiveFloat = 0.01
    range: PositiveFloat = 5.0
    placement: Literal["mean", "mode", "quantile"] = "mean"
    quantile: float = Field(0.5, gt=0.0, lt=1.0)
    max_trials: PositiveInt = 40
    sd_stop: PositiveFloat | None = None
    min_level: float = -np.inf
    max_level: float = np.inf
    scale: Literal["log10", "linear"] = "log10"

    @model_validator(mode="after")
    def _reachable(self):
        f = (self.p_threshold - self.delta * self.gamma) / (1.0 - self.delta)
        if not self.gamma < f < 1.0:
            raise ValueError(f"p_threshold must lie between the guess and lapse bounds "
                             f"({self.delta * self.gamma + (1 - self.delta) * self.gamma:.3g}, {1 - self.delta + self.delta * self.gamma:.3g})")
        if not self.min_level < self.max_level:
            raise ValueError("min_level must be below max_level")
        return self

    @property
    def eps(self) -> float:
        """psi(T) = p_threshold: 1 - (1 - gamma) exp(-10^(beta eps)) = (p - delta gamma) / (1 - delta)."""
        f = (self.p_threshold - self.delta * self.gamma) / (1.0 - self.delta)
        return float(np.log10(-np.log((1.0 - f) / (1.0 - self.gamma))) / self.beta)

    def psi(self, x, threshold) -> np.ndarray:
        """P(positive) at log intensity ``x`` for threshold ``threshold`` (broadcast)."""
        w = -np.expm1(np.log1p(-self.gamma) - 10.0 ** (self.beta * (np.asarray(x) - threshold + self.eps)))
        return self.delta * self.gamma + (1.0 - self.delta) * w


class Quest:
    """Read :attr:`level` (or :attr:`x`), present it, call :meth:`update` with the response until
    :attr:`finished`; :meth:`mean`, :meth:`sd`, :meth:`mode`, :meth:`quantile` read the
    posterior of T, :meth:`result` gives a :class:`~surfhap.lab.staircase.StaircaseResult`."""

    def __init__(self, params: QuestParams):
        p = self.params = params
        n = int(round(p.range / p.grain / 2))
        self.t = p.prior_mean + p.grain * np.arange(-n, n + 1)
        self.log_post = -0.5 * ((self.t - p.prior_mean) / p.prior_sd) ** 2
        self._buf = np.empty_like(self.t)
        self._x: list[float] = []
        self._responses: list[bool] = []
        self.x = self._place()

    def posterior(self) -> np.ndarray:
        """(m,) the normalised posterior over the grid :attr:`t`."""
        w = np.exp(self.log_post - self.log_post.max())
        return w / w.sum()

    def mean(self) -> float:
        return float(self.posterior() @ self.t)

    def sd(self) -> float:
        w = self.posterior()
        return float(np.sqrt(w @ (self.t - w @ self.t) ** 2))

    def mode(self) -> float:
        return float(self.t[int(np.argmax(self.log_post))])

    def quantile(self, q: float) -> float:
        return float(np.interp(q, np.cumsum(self.posterior()), self.t))

    def _place(self) -> float:
        p = self.params
        x = (self.mean() if p.placement == "mean" else self.mode() if p.placement == "mode" else
             self.quantile(p.quantile))
        return float(min(max(x, p.min_level), p.max_level))

    def _level(self, x: float) -> float:
        return float(10.0 ** x) if self.params.scale == "log10" else x

    @property
    def level(self) -> float:
        """The next level to present (``10**x`` for the log10 scale)."""
        return self._level(self.x)

    @property
    def finished(self) -> bool:
        p = self.params
        return len(self._x) >= p.max_trials or (p.sd_stop is not None and self.sd() < p.sd_stop)

    def update(self, positive: bool, x: float | None = None) -> None:
        """Record ``positive`` at log intensity ``x`` (default: the placed :attr:`x`) and place the next trial."""
        if self.finished:
            raise ConfigError("the QUEST run has finished", field="quest")
        x = self.x if x is None else float(x)
        b = self._buf
        np.copyto(b, self.params.psi(x, self.t))
        if not positive:
            np.subtract(1.0, b, out=b)
        with np.errstate(divide="ignore"):
            self.log_post += np.log(b, out=b)
        self._x.append(x)
        self._responses.append(bool(positive))
        self.x = self._place()

    def result(self):
        """Levels and responses; ``threshold`` is the posterior mean of T as a level (King-Smith et al. 1994)."""
        from surfhap.lab.staircase import StaircaseResult

        p = self.params
        stop = ("running" if not self.finished else "trials" if len(self._x) >= p.max_trials else "posterior SD")
        empty = np.zeros(0)
        return StaircaseResult(np.array([self._level(x) for x in self._x]), np.array(self._responses, dtype=bool),
                               empty.astype(int), empty, self._level(self.mean()) if self._x else None, stop)
