"""Low-band friction fits: Coulomb mu0 and the quasi-static law of Otake et al. (2022).

* Coulomb (Otake et al. 2021, Sec. II-B): ``mu0 = mean(shear) / mean(normal)`` over the
  contact samples.
* Quasi-static (Otake et al. 2022, eq. 3): ``mu_p = a fn^b (1 + d v^q) / (1 + c v)``
  fitted to the low-band CoF by bounded least squares (``scipy.optimize.least_squares``)
  with ``c, d >= 0``, ``0 <= q <= 1`` (and ``0 < a <= 5``, ``-2 <= b <= 2``): Levenberg–Marquardt
  without bounds first (the minimum is inside them on real data, and LM reaches it in a fraction
  of the evaluations), trust-region reflective with the bounds when LM's minimum is outside
  them or it fails. Both run to ``ftol = xtol = gtol = 1e-12``. The low band holds nothing above the cut-off, so the samples are
  decimated to four per cut-off period before fitting; standard errors come from the
  Jacobian at the optimum, ``sqrt(diag(s^2 (J^T J)^-1))``. Decimation reduces, but does
  not remove, the serial correlation of the residuals, so these asymptotic errors are
  optimistic; the across-participant standard errors of :func:`summarize_fits` (the
  statistic of 2022 Table I) are the ones written to material files when several
  participants were recorded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from surfhap.models.friction import QUASI_STATIC_RANGES, CoulombLaw, QuasiStaticLaw

__all__ = ["PARAMETERS", "CoulombFit", "QuasiStaticFit", "coulomb_from_sums", "fit_quasi_static", "summarize_fits", "quasi_static_model"]

PARAMETERS = tuple(QUASI_STATIC_RANGES)  # ("a", "b", "c", "d", "q")
_LOWER = np.array([QUASI_STATIC_RANGES[k][0] for k in PARAMETERS]) + np.array([1e-9, 0, 0, 0, 0])  # a > 0
_UPPER = np.array([QUASI_STATIC_RANGES[k][1] for k in PARAMETERS])
#: of both solvers; the flat (c, d, q) valley of eq. 3 needs ~300 evaluations on some participants
_TOLERANCES = {"ftol": 1e-12, "xtol": 1e-12, "gtol": 1e-12, "max_nfev": 1000}


@dataclass(frozen=True)
class CoulombFit:
    """mu0 = mean shear / mean normal; n contact samples; label (participant or "pooled")."""

    mu0: float
    n: int
    label: str = "pooled"

    @property
    def law(self) -> CoulombLaw:
        return CoulombLaw(self.mu0)


def coulomb_from_sums(shear_sum: float, normal_sum: float, n: int, label: str = "pooled") -> CoulombFit:
    """mu0 = sum(shear) / sum(normal) over n contact samples (= mean shear / mean normal)."""
    if not normal_sum > 0:
        raise ValueError("no contact samples to fit mu0")
    return CoulombFit(float(shear_sum / normal_sum), int(n), label)


def quasi_static_model(theta: np.ndarray, fn: np.ndarray, v: np.ndarray) -> np.ndarray:
    """mu_p for theta = (a, b, c, d, q), fn (n,) N > 0, v (n,) m/s >= 0 -> (n,): the one
    evaluation of eq. 3 (:meth:`QuasiStaticLaw.coefficient`)."""
    return QuasiStaticLaw(*map(float, theta)).coefficient(fn, v)


class _Residual:
    """Residual ``mu_p - mu`` and Jacobian of eq. 3 for ``least_squares``; the Jacobian at the
    last evaluated theta (every accepted step) reuses its mu_p, and the logs of fn and v are
    taken once."""

    def __init__(self, fn, v, mu):
        from surfhap.models.friction_kernel import quasi_static, quasi_static_jacobian

        self.fn, self.v, self.mu, self._law, self._jac = fn, v, mu, quasi_static, quasi_static_jacobian
        self.log_fn = np.log(fn)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.log_v = np.where(v > 0, np.log(np.where(v > 0, v, 1.0)), 0.0)
        self._theta = self._mu_p = None

    def residual(self, theta):
        """mu_p - mu (n,): the compiled eq. 3 (``QuasiStaticLaw.coefficient`` without
        re-validating theta, which the bounds keep in range)."""
        self._theta, self._mu_p = theta.copy(), np.empty(self.fn.size)
        self._law(self.fn, self.v, self._mu_p, *map(float, theta))
        return self._mu_p - self.mu

    def jacobian(self, theta):
        """d mu_p / d(a, b, c, d, q) (n, 5)."""
        a, b, c, d, q = map(float, theta)
        if not np.array_equal(theta, self._theta):
            self.residual(theta)
        J = np.empty((self.fn.size, 5))
        self._jac(self._mu_p, self.v, np.power(self.v, q), self.log_fn, self.log_v, a, c, d, J)
        return J


@dataclass(frozen=True)
class QuasiStaticFit:
    """Fitted quasi-static law.

    params          : {"a", "b", "c", "d", "q"} -> value.
    standard_errors : same keys; asymptotic (one fit) or across participants (summary).
    r2              : coefficient of determination on the fitted samples (mean over
                      participants for a summary).
    n               : samples fitted (or participants, for a summary).
    label           : participant, "pooled" or "mean of N participants".
    """

    params: dict
    standard_errors: dict
    r2: float
    n: int
    label: str = "pooled"

    @property
    def law(self) -> QuasiStaticLaw:
        return QuasiStaticLaw(**{k: float(self.params[k]) for k in PARAMETERS})

    @property
    def theta(self) -> np.ndarray:
        return np.array([self.params[k] for k in PARAMETERS])


def fit_quasi_static(fn: np.ndarray, v: np.ndarray, mu: np.ndarray, label: str = "pooled",
                     x0: Sequence[float] | None = None) -> QuasiStaticFit:
    """Bounded least-squares fit of mu (n,) against fn (n,) N and v (n,) m/s.

    Samples with fn <= 0 are ignored. The start is a log-log line for (a, b) with
    c = d = q = 0.5 (or ``x0``); at most 1000 evaluations per solver (module docstring).
    """
    fn = np.asarray(fn, dtype=float)
    v = np.abs(np.asarray(v, dtype=float))
    mu = np.asarray(mu, dtype=float)
    ok = (fn > 0) & np.isfinite(fn) & np.isfinite(v) & np.isfinite(mu)
    fn, v, mu = fn[ok], v[ok], mu[ok]
    if fn.size < 10:
        raise ValueError(f"only {fn.size} samples for the quasi-static fit (need >= 10)")
    # start: a, b from a log-log line, then (c, d, q) from a few guesses
    A = np.column_stack([np.ones(fn.size), np.log(fn)])
    pos = mu > 0
    if pos.sum() >= 2:
        coef, *_ = np.linalg.lstsq(A[pos], np.log(mu[pos]), rcond=None)
        a0, b0 = float(np.clip(np.exp(coef[0]), 1e-6, 5.0)), float(np.clip(coef[1], -1.9, 1.9))
    else:
        a0, b0 = max(float(np.mean(mu)), 1e-3), 0.0
    start = np.asarray(x0, dtype=float) if x0 is not None else np.array([a0, b0, 0.5, 0.5, 0.5])
    start = np.clip(start, _LOWER + 1e-6, np.where(np.isfinite(_UPPER), _UPPER - 1e-6, start + 1))
    res = _Residual(fn, v, mu)
    with np.errstate(all="ignore"):  # an LM trial step may leave eq. 3's domain (inf/NaN residuals, rejected)
        best = least_squares(res.residual, start, jac=res.jacobian, method="lm", x_scale="jac", **_TOLERANCES)
    if not (best.status > 0 and np.all(np.isfinite(best.fun)) and np.all((best.x >= _LOWER) & (best.x <= _UPPER))):
        best = least_squares(res.residual, start, jac=res.jacobian, bounds=(_LOWER, _UPPER), method="trf", x_scale="jac",
                             **_TOLERANCES)
    theta = best.x
    resid = best.fun
    dof = max(fn.size - 5, 1)
    s2 = float(resid @ resid) / dof
    J = best.jac  # at best.x
    try:
        cov = s2 * np.linalg.pinv(J.T @ J)
        se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        se = np.full(5, np.nan)
    ss_tot = float(np.sum((mu - mu.mean()) ** 2))
    r2 = 1.0 - float(resid @ resid) / ss_tot if ss_tot > 0 else float("nan")
    return QuasiStaticFit(dict(zip(PARAMETERS, map(float, theta))), dict(zip(PARAMETERS, map(float, se))), r2, int(fn.size), label)


def summarize_fits(fits: Sequence[QuasiStaticFit]) -> QuasiStaticFit:
    """Mean and standard error across participants (2022 Table I); r2 is the mean R^2."""
    if not fits:
        raise ValueError("no fits to summarise")
    thetas = np.array([f.theta for f in fits])
    k = len(fits)
    mean = thetas.mean(axis=0)
    se = thetas.std(axis=0, ddof=1) / np.sqrt(k) if k > 1 else np.array([fits[0].standard_errors[p] for p in PARAMETERS])
    r2 = float(np.mean([f.r2 for f in fits]))
    return QuasiStaticFit(dict(zip(PARAMETERS, map(float, mean))), dict(zip(PARAMETERS, map(float, se))), r2, k,
                          f"mean of {k} participant(s)")
