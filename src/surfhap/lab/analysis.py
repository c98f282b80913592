"""Statistics of perception studies on scipy / statsmodels, results as objects with named fields:
proportions with intervals, participant means, binomial / z / t tests, Bonferroni, confusion
matrices, Pearson correlation, repeated-measures and between-subjects factorial ANOVA and
KinesTouch discrimination scores (the aligned rank transform: :mod:`surfhap.lab.art`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable

__all__ = ["ProportionResult", "proportions", "participant_means", "TestResult", "binomial_test", "z_test_one",
           "z_test_two", "t_test", "bonferroni", "ConfusionResult", "confusion", "PearsonResult", "pearson",
           "AnovaResult", "rm_anova", "factorial_anova", "discrimination_score"]


@dataclass(frozen=True)
class ProportionResult(Result):
    """labels (k,), successes (k,) float, n (k,), proportion (k,), ci_low / ci_high (k,), within
    [0, 1] by construction; method ("wilson", "beta": trials pooled, n = trials; "participants":
    the mean of n participants, bootstrap interval), confidence, title; half_width (k,): for
    "participants" the printed form mean +- z sd / sqrt(n) of Otake et al. 2022 (may pass 0 or 1)."""

    labels: tuple[str, ...]
    successes: np.ndarray
    n: np.ndarray
    proportion: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    method: str
    confidence: float
    title: str = ""
    half_width: np.ndarray | None = None

    def rows(self) -> list[list]:
        return [[lab, f"{s:g}/{n:g}", f"{p:.3f}", f"[{lo:.3f}, {hi:.3f}]"]
                for lab, s, n, p, lo, hi in zip(self.labels, self.successes, self.n, self.proportion, self.ci_low,
                                                self.ci_high)]

    def summary(self) -> dict:
        return jsonable(asdict(self))

    def plot(self, ax=None, chance: float | None = None):
        """Bars with their intervals, and the ``chance`` level as a line."""
        from surfhap.report.lab_figures import plot_proportions

        return plot_proportions(self, ax, chance)


def _conf(confidence: float) -> float:
    if not 0 < confidence < 1:
        raise ConfigError("must be in (0, 1)", field="confidence")
    return confidence


def frame(records: Sequence[dict], columns: Sequence[str]):
    """``records`` as a pandas DataFrame; ConfigError naming a missing column."""
    import pandas as pd

    df = pd.DataFrame.from_records(list(records))
    for col in columns:
        if col not in df.columns:
            raise ConfigError(f"no column {col!r}", field="records")
    return df


def proportions(successes: Sequence[float], n: Sequence[float], labels: Sequence[str] | None = None,
                method: str = "wilson", confidence: float = 0.95, title: str = "") -> ProportionResult:
    """Pooled proportions successes/n with Wilson or Clopper-Pearson ("beta") intervals
    (statsmodels ``proportion_confint``; both lie within [0, 1])."""
    from statsmodels.stats.proportion import proportion_confint

    s = np.asarray(successes, dtype=float)
    m = np.asarray(n, dtype=float)
    if s.shape != m.shape or np.any(m <= 0) or np.any(s < 0) or np.any(s > m):
        raise ConfigError("need 0 <= successes <= n and n > 0", field="successes")
    if method not in ("wilson", "beta"):
        raise ConfigError("must be wilson or beta (Clopper-Pearson)", field="method")
    lo, hi = proportion_confint(s, m, alpha=1 - _conf(confidence), method=method)
    labs = tuple(labels) if labels is not None else tuple(str(i) for i in range(s.size))
    return ProportionResult(labs, s, m, s / m, np.asarray(lo, float), np.asarray(hi, float), method, confidence, title)


BOOTSTRAP_RESAMPLES = 9999  # scipy.stats.bootstrap's default n_resamples


def participant_means(values: Sequence[Sequence[float]], labels: Sequence[str] | None = None,
                      confidence: float = 0.95, ddof: int = 0, title: str = "", seed: int = 0) -> ProportionResult:
    """Mean over participants of per-participant proportions.

    values: one sequence per label, holding each participant's proportion (e.g. 0, 0.5, 1 for
    two trials). ``ci_low``/``ci_high``: percentile bootstrap over participants
    (:data:`BOOTSTRAP_RESAMPLES` resamples from ``seed``): quantiles of means of values in
    [0, 1], so within [0, 1]. ``half_width``: z_(1-a/2) sd_ddof / sqrt(n_participants), the
    printed +- of Otake et al. 2022 Tables II-III (population sd, ddof = 0)."""
    from scipy.stats import norm

    z = norm.ppf(0.5 + _conf(confidence) / 2)
    rng = np.random.default_rng(seed)
    means, ci, half, ns = [], [], [], []
    for v in values:
        a = np.asarray(v, dtype=float)
        if a.size < 2:
            raise ConfigError("need two participants or more per label", field="values")
        if np.any((a < 0) | (a > 1)):
            raise ConfigError("each participant's proportion must lie in [0, 1]", field="values")
        means.append(float(a.mean()))
        boot = a[rng.integers(0, a.size, (BOOTSTRAP_RESAMPLES, a.size))].mean(axis=1)
        ci.append(np.quantile(boot, [(1 - confidence) / 2, (1 + confidence) / 2]))
        half.append(z * float(a.std(ddof=ddof)) / np.sqrt(a.size))
        ns.append(a.size)
    labs = tuple(labels) if labels is not None else tuple(str(i) for i in range(len(means)))
    mean, ci = np.array(means), np.array(ci).reshape(-1, 2)
    return ProportionResult(labs, mean * np.array(ns), np.array(ns, float), mean, ci[:, 0], ci[:, 1],
                            "participants", confidence, title, np.array(half))


@dataclass(frozen=True)
class TestResult:
    """One test: name, statistic, p (unadjusted), df (or None), alternative, estimate."""

    name: str
    statistic: float
    p: float
    df: float | tuple[float, float] | None = None  # (between, within) for F
    alternative: str = "two-sided"
    estimate: float | None = None


_SM_ALTERNATIVE = {"two-sided": "two-sided", "greater": "larger", "less": "smaller"}  # statsmodels' names


def binomial_test(k: int, n: int, p0: float, alternative: str = "greater") -> TestResult:
    """Exact binomial test of k successes in n against chance p0 (scipy ``binomtest``)."""
    from scipy.stats import binomtest

    r = binomtest(int(k), int(n), p0, alternative=alternative)
    return TestResult("binomial", float(k), float(r.pvalue), None, alternative, k / n)


def z_test_one(k: float, n: float, p0: float, alternative: str = "two-sided") -> TestResult:
    """z test of a proportion k/n against p0 (statsmodels ``proportions_ztest``, null variance)."""
    from statsmodels.stats.proportion import proportions_ztest

    alt = _SM_ALTERNATIVE[alternative]
    z, p = proportions_ztest(k, n, value=p0, alternative=alt, prop_var=p0)
    return TestResult("z (one proportion)", float(z), float(p), None, alternative, k / n)


def z_test_two(k1: float, n1: float, k2: float, n2: float, alternative: str = "two-sided",
               pooled: bool = True) -> TestResult:
    """Two-proportion z test (statsmodels): pooled variance under the null (``proportions_ztest``)
    or unpooled Wald variance p1 q1 / n1 + p2 q2 / n2 (``test_proportions_2indep``, the form
    that reproduces Otake et al. 2022 Table IV)."""
    from statsmodels.stats.proportion import proportions_ztest, test_proportions_2indep

    alt = _SM_ALTERNATIVE[alternative]
    with np.errstate(invalid="ignore", divide="ignore"):  # both 0 % or both 100 %: z undefined (nan)
        if pooled:
            z, p = proportions_ztest([k1, k2], [n1, n2], alternative=alt)
        else:
            r = test_proportions_2indep(k1, n1, k2, n2, method="wald", compare="diff", alternative=alt)
            z, p = r.statistic, r.pvalue
    return TestResult(f"z (two proportions, {'pooled' if pooled else 'unpooled'})", float(z), float(p), None,
                      alternative, k1 / n1 - k2 / n2)


def t_test(a: Sequence[float], b: Sequence[float] | float | None = None, *, paired: bool = False,
           alternative: str = "two-sided") -> TestResult:
    """t test (scipy): one-sample against the number ``b``, paired, or independent (equal variances).
    Constant data give an infinite or undefined statistic (scipy's precision warning is silenced)."""
    import warnings

    from scipy import stats

    x = np.asarray(a, dtype=float)
    y = None if b is None or np.isscalar(b) else np.asarray(b, dtype=float)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=RuntimeWarning)
        if y is None:
            r = stats.ttest_1samp(x, float(b or 0.0), alternative=alternative)
            name, df, est = "one sample", x.size - 1, x.mean()
        elif paired:
            name, r, df, est = "paired", stats.ttest_rel(x, y, alternative=alternative), x.size - 1, np.mean(x - y)
        else:
            name, r, df, est = ("independent", stats.ttest_ind(x, y, alternative=alternative), x.size + y.size - 2,
                                x.mean() - y.mean())
    return TestResult(f"t ({name})", float(r.statistic), float(r.pvalue), float(df), alternative, float(est))


def bonferroni(p: Sequence[float]) -> np.ndarray:
    """Bonferroni-adjusted p-values, min(1, m p) (statsmodels ``multipletests``)."""
    from statsmodels.stats.multitest import multipletests

    return np.asarray(multipletests(np.asarray(p, dtype=float), method="bonferroni")[1])


@dataclass(frozen=True)
class ConfusionResult(Result):
    """labels (k,), counts (k, k) int (row = presented, column = answered), proportions (k, k)
    (each row divided by its total), accuracy (diagonal total / total), title."""

    labels: tuple[str, ...]
    counts: np.ndarray
    proportions: np.ndarray
    accuracy: float
    title: str = ""

    @property
    def per_class(self) -> np.ndarray:
        """(k,) proportion correct per presented label."""
        return np.diag(self.proportions)

    def summary(self) -> dict:
        return jsonable({"title": self.title, "labels": self.labels, "accuracy": self.accuracy,
                         "per_class": self.per_class})

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), **asdict(self)})

    def plot(self, ax=None):
        from surfhap.report.lab_figures import plot_confusion

        return plot_confusion(self, ax)


def confusion(presented: Sequence[str] | None = None, answered: Sequence[str] | None = None,
              labels: Sequence[str] | None = None, *, counts: np.ndarray | None = None,
              title: str = "") -> ConfusionResult:
    """Confusion matrix from paired lists of labels, or from a ``counts`` matrix."""
    if counts is None:
        pres = [str(x) for x in presented]
        ans = [str(x) for x in answered]
        if len(pres) != len(ans):
            raise ConfigError("presented and answered differ in length", field="answered")
        labs = list(labels) if labels is not None else sorted(set(pres) | set(ans))
        idx = {lab: i for i, lab in enumerate(labs)}
        c = np.zeros((len(labs), len(labs)), dtype=int)
        for p_, a_ in zip(pres, ans):
            if p_ in idx and a_ in idx:
                c[idx[p_], idx[a_]] += 1
    else:
        c = np.asarray(counts, dtype=int)
        labs = list(labels) if labels is not None else [str(i) for i in range(c.shape[0])]
        if c.ndim != 2 or c.shape[0] != c.shape[1] or c.shape[0] != len(labs):
            raise ConfigError("counts must be a square matrix matching the labels", field="counts")
    rows = c.sum(axis=1, keepdims=True)
    prop = np.divide(c, rows, out=np.zeros(c.shape), where=rows > 0)
    total = c.sum()
    return ConfusionResult(tuple(labs), c, prop, float(np.trace(c) / total) if total else float("nan"), title)


@dataclass(frozen=True)
class PearsonResult(Result):
    """r, p (two-sided t test with n - 2 df), n, ci_low / ci_high (Fisher z), and the data
    x (n,), y (n,), labels, x_name, y_name for the scatter plot."""

    r: float
    p: float
    n: int
    ci_low: float
    ci_high: float
    x: np.ndarray
    y: np.ndarray
    labels: tuple[str, ...] = ()
    x_name: str = "x"
    y_name: str = "y"

    def summary(self) -> dict:
        return jsonable({"r": self.r, "p": self.p, "n": self.n, "ci_low": self.ci_low, "ci_high": self.ci_high})

    def to_dict(self) -> dict:
        return jsonable(asdict(self))

    def plot(self, ax=None):
        """The scatter of y over x with the identity line."""
        from surfhap.report.lab_figures import plot_rating_scatter

        return plot_rating_scatter(self, ax)


def pearson(x: Sequence[float], y: Sequence[float], labels: Sequence[str] = (), x_name: str = "real",
            y_name: str = "virtual", confidence: float = 0.95) -> PearsonResult:
    """Pearson correlation (scipy ``pearsonr``) with its confidence interval."""
    from scipy.stats import pearsonr

    a = np.asarray(x, dtype=float)
    b = np.asarray(y, dtype=float)
    if a.shape != b.shape or a.size < 3:
        raise ConfigError("need two equally long samples of 3 or more", field="x")
    res = pearsonr(a, b)
    ci = res.confidence_interval(confidence_level=_conf(confidence))
    return PearsonResult(float(res.statistic), float(res.pvalue), int(a.size), float(ci.low), float(ci.high), a, b,
                         tuple(str(s) for s in labels), x_name, y_name)


@dataclass(frozen=True)
class AnovaResult(Result):
    """Factorial ANOVA: rows of (effect, F, df_num, df_den, p); subjects (observations when
    between-subjects); depvar; method."""

    rows: tuple[tuple[str, float, float, float, float], ...]
    subjects: int
    depvar: str
    method: str = "repeated-measures ANOVA"

    def effect(self, name: str) -> tuple[str, float, float, float, float]:
        """The row of effect ``name`` (KeyError if the ANOVA has none)."""
        return {r[0]: r for r in self.rows}[name]

    def summary(self) -> dict:
        return jsonable({"method": self.method, "depvar": self.depvar, "subjects": self.subjects,
                         "effects": [dict(zip(("effect", "F", "df_num", "df_den", "p"), r)) for r in self.rows]})

    def plot(self, ax=None):
        """F of every effect, labelled with its df and p."""
        from surfhap.report.lab_figures import plot_anova

        return plot_anova(self, ax)


def factorial_anova(records: Sequence[dict], depvar: str, factors: Sequence[str]) -> AnovaResult:
    """Between-subjects full-factorial ANOVA (every record one independent observation):
    statsmodels OLS with sum-to-zero contrasts, type III sums of squares."""
    import pandas as pd
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    df = frame(records, (depvar, *factors))
    data = pd.DataFrame({f"f{i}": df[f].astype(str) for i, f in enumerate(factors)})
    data["y"] = df[depvar].astype(float)
    terms = "*".join(f"C(f{i}, Sum)" for i in range(len(factors)))
    tab = anova_lm(smf.ols(f"y ~ {terms}", data).fit(), typ=3)
    res = tab.loc["Residual"]
    rows = tuple((":".join(factors[int(t.split(",")[0][3:])] for t in str(idx).split(":")), float(r["F"]),
                  float(r["df"]), float(res["df"]), float(r["PR(>F)"]))
                 for idx, r in tab.iterrows() if str(idx).startswith("C("))
    return AnovaResult(rows, len(df), depvar, "between-subjects ANOVA")


def rm_anova(records: Sequence[dict], depvar: str, subject: str, within: Sequence[str]) -> AnovaResult:
    """Repeated-measures ANOVA over ``records`` (dicts with the subject, the within factors
    and the dependent variable); repetitions are averaged per subject and cell (statsmodels
    ``AnovaRM``, which needs every subject in every cell)."""
    import pandas as pd
    from statsmodels.stats.anova import AnovaRM

    df = frame(records, (depvar, subject, *within))
    # integer codes for the factors: AnovaRM silently drops some string-typed factors (pandas 3)
    for col in (subject, *within):
        df[col] = pd.factorize(df[col].astype(str), sort=True)[0]
    df[depvar] = df[depvar].astype(float)
    # AnovaRM (statsmodels 0.15) loses factors depending on their names (e.g. a factor sorting
    # after the subject column): run it on neutral names f0, f1, ... and map them back
    names = {w: f"f{i}" for i, w in enumerate(within)}
    df = df.rename(columns={**names, subject: "zsubject", depvar: "zvalue"})
    inner = list(names.values())
    cells = df.groupby(["zsubject", *inner])["zvalue"].mean().reset_index()
    n_cells = int(np.prod([cells[w].nunique() for w in inner]))
    complete = cells.groupby("zsubject").size() == n_cells
    cells = cells[cells["zsubject"].isin(complete[complete].index)]
    if cells["zsubject"].nunique() < 2:
        raise ConfigError("need two subjects or more with data in every cell", field="records")
    tab = AnovaRM(cells, "zvalue", "zsubject", within=inner).fit().anova_table
    back = {v: k for k, v in names.items()}
    rows = tuple((":".join(back[x] for x in str(idx).split(":")), float(r["F Value"]), float(r["Num DF"]),
                  float(r["Den DF"]), float(r["Pr > F"])) for idx, r in tab.iterrows())
    if len(rows) != 2 ** len(within) - 1:
        raise ConfigError("the ANOVA lost an effect (constant or collinear factor?)", field="records")
    return AnovaResult(rows, int(cells["zsubject"].nunique()), depvar)


def discrimination_score(preference_rate: float | np.ndarray) -> float | np.ndarray:
    """KinesTouch discrimination score |2p - 1| for a preference rate p in [0, 1]
    (Sec. 5.2, Table 3: 50 % -> 0, 75 % -> 0.5, 100 % -> 1)."""
    p = np.asarray(preference_rate, dtype=float)
    if np.any((p < 0) | (p > 1)):
        raise ConfigError("a preference rate must be in [0, 1]", field="preference_rate")
    out = np.abs(2.0 * p - 1.0)
    return float(out) if out.ndim == 0 else out
