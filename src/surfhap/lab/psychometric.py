"""Psychometric-function fitting by maximum likelihood, with parametric bootstrap intervals.

The proportion correct at stimulus level ``x`` is

    psi(x) = guess + (1 - guess - lapse) * F(x; threshold, slope)

with the guess rate fixed by the task (0.5 for 2AFC, 1/3 for 3AFC, 0 for yes/no) and the
lapse rate fixed or fitted within ``[0, MAX_LAPSE]``. The shapes ``F`` (Wichmann & Hill 2001):

* ``logistic``: ``1 / (1 + exp(-slope (x - threshold)))``; with no guess and no lapse this is the
  logit GLM ``b0 + b1 x`` with ``slope = b1`` and ``threshold = -b0 / b1``;
* ``normal``: ``Phi(slope (x - threshold))`` (the probit GLM, same relation; ``1/slope`` is the SD);
* ``gumbel`` (log-Weibull): ``1 - exp(-exp(slope (x - threshold)))``;
* ``weibull``: ``1 - exp(-(x / threshold)^slope)`` for ``x > 0``, i.e. ``gumbel`` in ``ln x``.

``threshold`` is where ``F`` is 0.5 (logistic, normal) or ``1 - 1/e`` (gumbel, weibull).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable

__all__ = ["MAX_LAPSE", "PsychometricFit", "fit_psychometric", "psychometric"]

Shape = Literal["logistic", "normal", "gumbel", "weibull"]
MAX_LAPSE = 0.1
_PARAMS = ("threshold", "slope", "lapse")


def _core(shape: str, z: np.ndarray) -> np.ndarray:
    """F as a function of ``z = slope (u - location)``, ``u`` being ``ln x`` for weibull."""
    from scipy.special import expit, ndtr

    return expit(z) if shape == "logistic" else ndtr(z) if shape == "normal" else -np.expm1(-np.exp(z))


def psychometric(x, threshold: float, slope: float, guess: float = 0.0, lapse: float = 0.0,
                 shape: Shape = "logistic") -> np.ndarray:
    """psi(x) (the module docstring) at levels ``x`` (any shape, same shape out)."""
    x = np.asarray(x, dtype=float)
    if shape == "weibull":
        with np.errstate(divide="ignore"):
            z = slope * (np.log(x) - np.log(threshold))
    else:
        z = slope * (x - threshold)
    return guess + (1.0 - guess - lapse) * _core(shape, z)


@dataclass(frozen=True)
class PsychometricFit(Result):
    """A maximum-likelihood fit: ``shape``, ``threshold``, ``slope``, ``guess``, ``lapse``
    (fitted if ``lapse_fitted``), ``loglik`` (the binomial log-likelihood without the constant),
    the data ``levels``, ``trials``, ``correct`` (n,), and ``ci``: name -> (low, high) 95 %
    parametric-bootstrap percentile intervals (empty if ``n_boot == 0``)."""

    shape: str
    threshold: float
    slope: float
    guess: float
    lapse: float
    lapse_fitted: bool
    loglik: float
    levels: np.ndarray
    trials: np.ndarray
    correct: np.ndarray
    n_boot: int = 0
    ci: dict = field(default_factory=dict)

    def psi(self, x) -> np.ndarray:
        """The fitted proportion correct at levels ``x`` (any shape)."""
        return psychometric(x, self.threshold, self.slope, self.guess, self.lapse, self.shape)

    def summary(self) -> dict:
        return jsonable({"shape": self.shape, "threshold": self.threshold, "slope": self.slope,
                         "guess": self.guess, "lapse": self.lapse, "lapse_fitted": self.lapse_fitted,
                         "loglik": self.loglik, "trials": int(self.trials.sum()), "n_boot": self.n_boot,
                         "ci": self.ci})

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), "levels": self.levels, "trials_per_level": self.trials,
                         "correct": self.correct})

    def plot(self, ax=None):
        """Proportion correct per level (marker area ~ trials), the fitted curve, the threshold and its CI."""
        from surfhap.report.lab_figures import plot_psychometric

        return plot_psychometric(self, ax)


def _check(levels, trials, correct, shape: str, guess: float, lapse: float | None):
    x = np.asarray(levels, dtype=float)
    n, k = np.asarray(trials), np.asarray(correct)
    if x.ndim != 1 or x.size < 2 or not np.all(np.isfinite(x)):
        raise ConfigError("must be a 1-D array of at least 2 finite stimulus levels", field="levels")
    for name, a in (("trials", n), ("correct", k)):
        if a.shape != x.shape:
            raise ConfigError(f"shape {a.shape} differs from levels {x.shape}", field=name)
        if not np.all(np.isfinite(a)) or np.any(a != np.round(a)) or np.any(a < 0):
            raise ConfigError("must be non-negative whole counts", field=name)
    if np.any(k > n):
        raise ConfigError("exceeds trials at some level", field="correct")
    if n.sum() == 0:
        raise ConfigError("no trials at all", field="trials")
    if shape not in ("logistic", "normal", "gumbel", "weibull"):
        raise ConfigError(f"unknown shape {shape!r} (logistic, normal, gumbel, weibull)", field="shape")
    if shape == "weibull" and np.any(x <= 0):
        raise ConfigError("must be > 0 for the weibull shape", field="levels")
    if not 0.0 <= guess < 1.0:
        raise ConfigError(f"{guess} is not in [0, 1)", field="guess")
    if lapse is not None and not 0.0 <= lapse <= MAX_LAPSE:
        raise ConfigError(f"{lapse} is not in [0, {MAX_LAPSE}]", field="lapse")
    return x, n.astype(float), k.astype(float)


def _nll(p, u, n, k, shape, guess, lapse):
    """Negative log-likelihood of ``p = (location, ln slope[, lapse])`` for levels ``u`` (n,)."""
    lam = p[2] if lapse is None else lapse
    prob = guess + (1.0 - guess - lam) * _core(shape, np.exp(p[1]) * (u - p[0]))
    prob = np.clip(prob, 1e-12, 1.0 - 1e-12)
    return -float(np.sum(k * np.log(prob) + (n - k) * np.log1p(-prob)))


def _fit(u, n, k, shape, guess, lapse, start=None, ftol=1e-15):
    """The ML ``(location, slope, lapse, loglik)`` of counts ``n, k`` (n,) at levels ``u`` (n,)."""
    from scipy.optimize import minimize

    args = (u, n, k, shape, guess, lapse)
    if start is None:  # coarse grid over location and slope so the local search starts in the right basin
        span = float(np.ptp(u)) or 1.0
        a, b = np.meshgrid(np.linspace(u.min() - 0.25 * span, u.max() + 0.25 * span, 25),
                           np.log(np.geomspace(0.1, 100.0, 25) / span))
        lam0 = 0.02 if lapse is None else lapse
        grid = guess + (1 - guess - lam0) * _core(shape, np.exp(b.ravel())[:, None] * (u - a.ravel()[:, None]))
        grid = np.clip(grid, 1e-12, 1 - 1e-12)
        best = int(np.argmax(k @ np.log(grid).T + (n - k) @ np.log1p(-grid).T))
        start = np.array([a.ravel()[best], b.ravel()[best]] + ([lam0] if lapse is None else []))
    bounds = [(None, None), (None, None)] + ([(0.0, MAX_LAPSE)] if lapse is None else [])
    res = minimize(_nll, start, args=args, method="L-BFGS-B", bounds=bounds,
                   options={"ftol": ftol, "gtol": 1e-10, "maxiter": 2000})
    lam = float(res.x[2]) if lapse is None else float(lapse)
    return float(res.x[0]), float(np.exp(res.x[1])), lam, -float(res.fun), res.x


def fit_psychometric(levels, trials, correct, *, shape: Shape = "logistic", guess: float = 0.0,
                     lapse: float | None = 0.0, n_boot: int = 0, seed: int | np.random.Generator = 0,
                     ) -> PsychometricFit:
    """Fit psi (module docstring) to ``correct`` of ``trials`` (n,) whole counts at ``levels`` (n,).

    ``lapse`` None fits it within ``[0, MAX_LAPSE]``; a number fixes it. ``n_boot > 0`` adds 95 %
    percentile intervals from a parametric bootstrap: ``n_boot`` data sets drawn from the fitted
    function with the same trials per level (``seed``: an int or a numpy Generator), each refitted.
    Raises :class:`ConfigError` naming the argument for bad input."""
    x, n, k = _check(levels, trials, correct, shape, guess, lapse)
    if n_boot < 0:
        raise ConfigError(f"{n_boot} is negative", field="n_boot")
    u = np.log(x) if shape == "weibull" else x
    loc, slope, lam, ll, p = _fit(u, n, k, shape, guess, lapse)
    ci = {}
    if n_boot:
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        prob = psychometric(u, loc, slope, guess, lam, "gumbel" if shape == "weibull" else shape)
        draws = np.array([_fit(u, n, rng.binomial(n.astype(int), prob).astype(float), shape, guess, lapse,
                               start=p, ftol=1e-10)[:3] for _ in range(n_boot)])
        if shape == "weibull":
            draws[:, 0] = np.exp(draws[:, 0])
        names = _PARAMS if lapse is None else _PARAMS[:2]
        ci = {name: tuple(float(v) for v in np.percentile(draws[:, i], [2.5, 97.5])) for i, name in enumerate(names)}
    return PsychometricFit(shape=shape, threshold=float(np.exp(loc) if shape == "weibull" else loc), slope=slope, guess=float(guess),
                           lapse=lam, lapse_fitted=lapse is None, loglik=ll, levels=x,
                           trials=n.astype(int), correct=k.astype(int), n_boot=int(n_boot), ci=ci)
