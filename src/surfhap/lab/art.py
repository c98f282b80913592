"""Aligned rank transform (ART; Wobbrock, Findlater, Gergle & Higgins 2011, CHI; Higgins,
Blair & Tashtoush 1990) for nonparametric factorial ANOVAs, on statsmodels.

For each effect E of the full factorial model over the fixed factors, the response is aligned,
``residual + estimated effect of E`` (residual: response minus its cell mean over all fixed
factors; estimated effect: the inclusion-exclusion sum of marginal means, e.g. for A:B
``mean_AB - mean_A - mean_B + grand mean``), ranked (average ranks, ties after rounding to
8 digits as ARTool does), and the full factorial ANOVA is run on the ranks; only E's row is
reported. Subjects are ignored by the alignment and enter the ANOVA only: a repeated-measures
ANOVA (statsmodels ``AnovaRM``, the ``Error(S/(A*B*...))`` model of ARTool) when a subject is
given, an ordinary least-squares factorial ANOVA otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from surfhap.lab.analysis import AnovaResult, factorial_anova, frame, rm_anova

__all__ = ["ArtResult", "align", "art_anova"]


@dataclass(frozen=True)
class ArtResult(AnovaResult):
    """:class:`AnovaResult` of the aligned ranks (one row per effect, each from its own
    alignment) and ``aligned``: effect name -> aligned (unranked) responses in record order."""

    aligned: dict = field(default_factory=dict)


def _effects(factors: Sequence[str]) -> list[tuple[str, ...]]:
    return [e for k in range(1, len(factors) + 1) for e in combinations(factors, k)]


def align(records: Sequence[dict], depvar: str, factors: Sequence[str]) -> dict[str, np.ndarray]:
    """Aligned responses for every effect of the full factorial model over ``factors``."""
    df = frame(records, (depvar, *factors))
    y = df[depvar].astype(float)
    df[depvar] = y
    mean = {(): float(y.mean())}
    for sub in _effects(factors):
        mean[sub] = df.groupby(list(sub))[depvar].transform("mean").to_numpy()
    resid = y.to_numpy() - mean[tuple(factors)]
    return {":".join(e): resid + sum((-1) ** (len(e) - k) * mean[s] for k in range(len(e) + 1)
                                     for s in combinations(e, k))
            for e in _effects(factors)}


def art_anova(records: Sequence[dict], depvar: str, subject: str | None, factors: Sequence[str]) -> ArtResult:
    """ART over ``records``: repeated-measures (every factor within ``subject``) or, with
    ``subject=None``, between-subjects. Rows: (effect, F, df_num, df_den, p)."""
    from scipy.stats import rankdata

    recs = list(records)
    aligned = align(recs, depvar, factors)
    rows, n = [], len(recs)
    for name, a in aligned.items():
        ranked = [{**r, depvar: float(x)} for r, x in zip(recs, rankdata(np.round(a, 8)))]
        an = (rm_anova(ranked, depvar, subject, factors) if subject is not None
              else factorial_anova(ranked, depvar, factors))
        rows.append(an.effect(name))
        n = an.subjects
    return ArtResult(tuple(rows), n, depvar, "aligned rank transform", aligned)

