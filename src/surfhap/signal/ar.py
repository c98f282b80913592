"""Autoregressive (AR) estimation: autocovariance, Levinson–Durbin, Yule–Walker, order selection.

Convention used everywhere in surfhap (Otake et al. 2022, eq. 4)::

    x[n] = sum_{j=1..p} phi[j-1] * x[n-j] + w[n],     w ~ N(0, sigma2)

``phi`` are the *prediction* coefficients (the sign convention of statsmodels'
``yule_walker``); the polynomial ``A(z) = 1 - sum phi_j z^-j`` is its denominator form.

All functions are pure and vectorised. The Levinson–Durbin recursion is written here
(it is a dozen lines) because it yields every order 0..P in one pass, which is what order
selection needs; it is checked against ``statsmodels.regression.linear_model.yule_walker``
and ``statsmodels.tsa.stattools.levinson_durbin`` in the tests.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from surfhap.results import Result, jsonable

__all__ = [
    "autocovariance",
    "levinson_durbin",
    "LevinsonResult",
    "yule_walker",
    "information_criteria",
    "select_order",
    "OrderSelection",
    "check_criterion",
    "order_selection",
    "ar_moments",
    "ar_psd",
    "ar_is_stable",
]


def autocovariance(x: np.ndarray, max_lag: int, demean: bool = True) -> np.ndarray:
    """Biased autocovariance ``r[k] = (1/n) sum_t x[t] x[t+k]`` for ``k = 0..max_lag``.

    x : (n,) float. Returns (max_lag + 1,) float. Computed with a zero-padded FFT,
    O(n log n); identical to ``statsmodels.tsa.stattools.acovf(x, adjusted=False)``.
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n == 0:
        raise ValueError("autocovariance of an empty signal")
    if max_lag < 0 or max_lag >= n:
        raise ValueError(f"max_lag must be in [0, {n - 1}], got {max_lag}")
    if demean:
        x = x - x.mean()
    nfft = 1 << int(np.ceil(np.log2(2 * n - 1)))
    spec = np.fft.rfft(x, nfft)
    r = np.fft.irfft(spec.real**2 + spec.imag**2, nfft)[: max_lag + 1]
    return r / n


@dataclass(frozen=True)
class LevinsonResult:
    """Every AR order from one Levinson–Durbin pass.

    coefficients : (P + 1, P) float, row p holds phi for order p in its first p columns.
    variances    : (P + 1,) float, innovation variance sigma2 for each order (row 0: r[0]).
    reflection   : (P,) float, reflection (partial autocorrelation) coefficients.
    """

    coefficients: np.ndarray
    variances: np.ndarray
    reflection: np.ndarray

    def order(self, p: int) -> tuple[np.ndarray, float]:
        """(phi (p,), sigma2) of order p."""
        return self.coefficients[p, :p].copy(), float(self.variances[p])


def levinson_durbin(acov: np.ndarray, max_order: int) -> LevinsonResult:
    """Solve the Yule–Walker equations for all orders 0..max_order.

    acov : (>= max_order + 1,) autocovariance with acov[0] > 0.
    """
    r = np.asarray(acov, dtype=float)
    if r.size < max_order + 1:
        raise ValueError("need max_order + 1 autocovariance lags")
    if not r[0] > 0:
        raise ValueError("autocovariance at lag 0 must be positive (constant signal?)")
    coefs = np.zeros((max_order + 1, max_order))
    variances = np.empty(max_order + 1)
    variances[0] = r[0]
    for k in range(1, max_order + 1):
        prev = coefs[k - 1, : k - 1]
        err = variances[k - 1]
        kk = (r[k] - prev @ r[k - 1 : 0 : -1]) / err if err > 0 else 0.0
        coefs[k, : k - 1] = prev - kk * prev[::-1]
        coefs[k, k - 1] = kk  # the reflection coefficient of order k
        variances[k] = max(err * (1.0 - kk * kk), 0.0)
    return LevinsonResult(coefs, variances, np.diagonal(coefs[1:]).copy())


def yule_walker(x: np.ndarray, order: int, demean: bool = True) -> tuple[np.ndarray, float]:
    """Yule–Walker AR fit with the biased ("mle") autocovariance.

    x : (n,) float. Returns phi (order,) and the innovation variance sigma2 (float).
    Equals statsmodels ``yule_walker(x, order, method="mle")`` (which returns sigma, the
    square root of sigma2).
    """
    r = autocovariance(x, order, demean=demean)
    return levinson_durbin(r, order).order(order)


def information_criteria(variances: np.ndarray, n: float) -> tuple[np.ndarray, np.ndarray]:
    """AIC and BIC for each order p = 0..P from the innovation variances.

    Uses the Gaussian log-likelihood ``-2 L = n log(sigma2_p) + const``, so
    ``AIC(p) = n log sigma2_p + 2 p`` (Otake et al. 2021, eq. 3) and
    ``BIC(p) = n log sigma2_p + p log n``. ``n`` may be an equivalent (non-integer) number
    of samples, e.g. for tapered data. Returns two (P + 1,) arrays.
    """
    v = np.maximum(np.asarray(variances, dtype=float), np.finfo(float).tiny)
    p = np.arange(v.size)
    base = n * np.log(v)
    return base + 2.0 * p, base + p * np.log(n)


@dataclass(frozen=True)
class OrderSelection(Result):
    """Result of :func:`select_order`.

    order          : chosen order.
    coefficients   : (order,) phi at the chosen order.
    variance       : innovation variance at the chosen order.
    orders         : (P - min_order + 1,) candidate orders.
    aic, bic       : criteria for the candidate orders, same shape as ``orders``.
    criterion      : "aic" or "bic".
    n              : number of samples used.
    """

    order: int
    coefficients: np.ndarray
    variance: float
    orders: np.ndarray
    aic: np.ndarray
    bic: np.ndarray
    criterion: str
    n: int

    @property
    def aic_order(self) -> int:
        """Order at the AIC minimum."""
        return int(self.orders[int(np.argmin(self.aic))])

    @property
    def bic_order(self) -> int:
        """Order at the BIC minimum."""
        return int(self.orders[int(np.argmin(self.bic))])

    def summary(self) -> dict:
        return {"order": self.order, "criterion": self.criterion, "aic_order": self.aic_order,
                "bic_order": self.bic_order, "variance": float(self.variance), "n": int(self.n)}

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), **asdict(self)})

    def plot(self, ax=None):
        """Plot the criteria against the order (see :mod:`surfhap.report.figures`)."""
        from surfhap.report.figures import plot_order_selection

        return plot_order_selection(self, ax=ax)


def check_criterion(criterion: str) -> str:
    """``criterion`` lower-cased, if it is "aic" or "bic" (else ValueError)."""
    if criterion.lower() not in ("aic", "bic"):
        raise ValueError(f"criterion must be 'aic' or 'bic', got {criterion!r}")
    return criterion.lower()


def order_selection(lev: LevinsonResult, n: float, criterion: str = "aic", min_order: int = 1) -> OrderSelection:
    """The AIC (or BIC) minimum over orders ``min_order..P`` of one Levinson–Durbin (or Burg)
    pass over ``n`` (equivalent) samples, as an :class:`OrderSelection`."""
    criterion = check_criterion(criterion)
    aic, bic = information_criteria(lev.variances, n)
    sl = slice(min_order, None)
    order = int(min_order + np.argmin(aic[sl] if criterion == "aic" else bic[sl]))
    phi, var = lev.order(order)
    return OrderSelection(order, phi, var, np.arange(min_order, lev.variances.size), aic[sl], bic[sl], criterion, int(round(n)))


def select_order(
    x: np.ndarray,
    max_order: int = 100,
    criterion: str = "aic",
    min_order: int = 1,
    demean: bool = True,
) -> OrderSelection:
    """Choose the AR order by AIC (or BIC) over ``min_order..max_order`` in one pass.

    x : (n,) float. One FFT autocovariance plus one Levinson–Durbin recursion gives all
    orders at once; the coefficients at the chosen order are the Yule–Walker ("mle") ones.
    """
    x = np.asarray(x, dtype=float)
    if not 0 <= min_order <= max_order:
        raise ValueError("need 0 <= min_order <= max_order")
    if x.size <= max_order + 1:
        raise ValueError(f"need more than {max_order + 1} samples for max_order={max_order}")
    if not np.all(np.isfinite(x)):
        raise ValueError("signal contains NaN or inf")
    lev = levinson_durbin(autocovariance(x, max_order, demean=demean), max_order)
    return order_selection(lev, x.size, criterion, min_order)


def ar_psd(coefficients: np.ndarray, variance: float, sample_rate: float, freqs: np.ndarray,
           ma: np.ndarray = ()) -> np.ndarray:
    """One-sided power spectral density of an AR (ARMA) process, in units^2/Hz: the one AR
    spectrum of surfhap (AR banks, interpolated ARMA banks, calibration, gain planning).

    ``x[n] = sum_j phi_j x[n-j] + w[n] + sum_k theta_k w[n-k]``, ``var(w) = variance``;
    ``S(f) = 2 sigma2 / fs |1 + sum_k theta_k z^k|^2 / |1 - sum_j phi_j z^j|^2`` with
    ``z = exp(-i 2 pi f / fs)`` (the one-sided convention of ``scipy.signal.welch``; the factor
    2 is dropped at 0 and Nyquist by Welch, so compare away from those edges).
    coefficients phi (p,), ma theta (q,), freqs (m,) Hz. Returns (m,) float.
    """
    z = np.exp(-2j * np.pi * np.asarray(freqs, dtype=float) / sample_rate)
    a = np.polyval(np.concatenate(([1.0], -np.asarray(coefficients, dtype=float).reshape(-1)))[::-1], z)
    psd = 2.0 * variance / sample_rate / np.abs(a) ** 2
    ma = np.asarray(ma, dtype=float).reshape(-1)
    return psd * np.abs(np.polyval(np.concatenate(([1.0], ma))[::-1], z)) ** 2 if ma.size else psd


def ar_moments(coefficients: np.ndarray, variance: float, sample_rate: float, ma: np.ndarray = (),
               n: int = 1 << 14) -> tuple[float, float]:
    """Standard deviation of the process (units) and of its rate of change (units/s) as a
    band-limited signal at ``sample_rate`` Hz: square roots of the integrals of :func:`ar_psd`
    and of ``(2 pi f)^2`` times it over 0 to Nyquist (``n`` points, trapezoid rule)."""
    f = np.linspace(0.0, sample_rate / 2, n)
    psd = ar_psd(coefficients, variance, sample_rate, f, ma)
    var = float(np.trapezoid(psd, f))
    slope_var = float(np.trapezoid(psd * (2 * np.pi * f) ** 2, f))
    return float(np.sqrt(max(var, 0.0))), float(np.sqrt(max(slope_var, 0.0)))


def ar_is_stable(coefficients: np.ndarray) -> bool:
    """True when all roots of ``z^p - phi_1 z^(p-1) - ... - phi_p`` lie inside the unit circle."""
    phi = np.asarray(coefficients, dtype=float)
    if phi.size == 0:
        return True
    roots = np.roots(np.concatenate(([1.0], -phi)))
    return bool(np.all(np.abs(roots) < 1.0))
