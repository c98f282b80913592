"""The aligned rank transform (surfhap.lab.art) against the procedure of Wobbrock, Findlater,
Gergle & Higgins (2011, CHI, Sec. "The ART procedure", steps 1-5) written out here with numpy,
against Kruskal-Wallis (the one-factor case), and against Wobbrock's correctness check."""

from itertools import combinations

import numpy as np
import pytest
from scipy import stats

from surfhap.lab.analysis import factorial_anova, rm_anova
from surfhap.lab.art import align, art_anova

LEVELS = (3, 2, 2)  # comparison, visual, tactile of the KinesTouch design


def _wobbrock(Y):
    """Y (subjects, a, b, c): for every effect, steps 1-5 of Wobbrock et al. 2011 and the
    repeated-measures F of the ranks from its sums of squares (subject x effect as error)."""
    S = Y.shape[0]
    cell = Y.mean(axis=0)  # step 1: residual = Y - cell mean (subjects are not a fixed factor)
    out = {}
    for k in (1, 2, 3):
        for eff in combinations((0, 1, 2), k):
            # step 2: estimated effect = inclusion-exclusion of the marginal means
            est = np.zeros(LEVELS)
            for j in range(k + 1):
                for sub in combinations(eff, j):
                    other = tuple(a for a in range(3) if a not in sub)
                    est = est + (-1) ** (k - j) * cell.mean(axis=other, keepdims=True)
            aligned = Y - cell + est  # step 3
            R = stats.rankdata(np.round(aligned, 8)).reshape(Y.shape)  # step 4: average ranks
            # step 5: the full-factorial repeated-measures ANOVA of R, effect `eff` only:
            other = tuple(a + 1 for a in range(3) if a not in eff)
            Z = R.mean(axis=other)  # (S, levels of eff)
            for a in range(1, Z.ndim):
                Z = Z - Z.mean(axis=a, keepdims=True)  # the effect's interaction contrast
            E = Z.mean(axis=0)
            df1 = int(np.prod([LEVELS[a] - 1 for a in eff]))
            F = (S * (E ** 2).sum() / df1) / (((Z - E) ** 2).sum() / (df1 * (S - 1)))
            out[":".join("cvt"[a] for a in eff)] = (F, df1, df1 * (S - 1))
    return out


def _records(Y):
    return [{"s": s, "c": c, "v": v, "t": t, "y": float(Y[s, c, v, t])} for s in range(Y.shape[0])
            for c in range(3) for v in range(2) for t in range(2)]


def test_art_follows_wobbrocks_procedure_on_tied_scores():
    Y = np.random.default_rng(3).integers(0, 11, (12, *LEVELS)) / 10  # KinesTouch-like scores, many ties
    Y[:, :, 1] += 0.3  # a visual effect
    res = art_anova(_records(Y), "y", "s", ["c", "v", "t"])
    ref = _wobbrock(Y)
    assert [r[0] for r in res.rows] == list(ref)
    for name, F, d1, d2, p in res.rows:
        assert F == pytest.approx(ref[name][0], rel=1e-9) and (d1, d2) == ref[name][1:]
        assert p == pytest.approx(stats.f.sf(F, d1, d2))
    assert res.effect("v")[4] < 0.05 and res.summary()["method"] == "aligned rank transform"


def test_alignment_strips_every_other_effect():
    """Wobbrock et al. 2011, "Correctness check": each aligned column sums to 0, and a full
    factorial ANOVA of an aligned (unranked) column finds F ~ 0 for every other effect."""
    rng = np.random.default_rng(7)
    Y = rng.normal(size=(10, *LEVELS)) + np.arange(3)[None, :, None, None] + 0.7 * np.arange(2)[None, None, :, None]
    recs = _records(Y)
    for name, a in align(recs, "y", ["c", "v", "t"]).items():
        assert abs(a.sum()) < 1e-9
        an = rm_anova([{**r, "y": float(x)} for r, x in zip(recs, a)], "y", "s", ["c", "v", "t"])
        assert all(F < 1e-9 for e, F, *_ in an.rows if e != name)
        assert an.effect(name)[1] > 0


def test_one_factor_art_is_kruskal_wallis():
    """With one between-subjects factor the aligned response is y - grand mean, so ART is the
    ANOVA of the ranks: F = H (N - k) / ((k - 1)(N - 1 - H)) with H the tie-corrected
    Kruskal-Wallis statistic (scipy)."""
    rng = np.random.default_rng(11)
    groups = [np.round(rng.normal(m, 1, n), 1) for m, n in ((0, 9), (0.8, 11), (1.5, 10))]
    recs = [{"g": str(i), "y": float(y)} for i, g in enumerate(groups) for y in g]
    (name, F, d1, d2, p), = art_anova(recs, "y", None, ["g"]).rows
    H, p_kw = stats.kruskal(*groups)
    N, k = len(recs), 3
    assert (d1, d2) == (k - 1, N - k)
    assert F == pytest.approx(H * (N - k) / ((k - 1) * (N - 1 - H)), rel=1e-9)


def test_between_subjects_factorial_anova_matches_hand_sums_of_squares():
    """factorial_anova (the between-subjects ANOVA of 000 and of ART without subjects) on a
    balanced 2 x 3 design against the textbook sums of squares."""
    Y = np.random.default_rng(5).integers(1, 8, (2, 3, 7)).astype(float)
    recs = [{"a": i, "b": j, "y": Y[i, j, r]} for i in range(2) for j in range(3) for r in range(7)]
    g, ma, mb, mc = Y.mean(), Y.mean(axis=(1, 2)), Y.mean(axis=(0, 2)), Y.mean(axis=2)
    sse = ((Y - mc[..., None]) ** 2).sum()
    ss = {"a": 21 * ((ma - g) ** 2).sum(), "b": 14 * ((mb - g) ** 2).sum(),
          "a:b": 7 * ((mc - ma[:, None] - mb[None] + g) ** 2).sum()}
    df = {"a": 1, "b": 2, "a:b": 2}
    for name, F, d1, d2, p in factorial_anova(recs, "y", ["a", "b"]).rows:
        assert (d1, d2) == (df[name], 36) and F == pytest.approx(ss[name] / d1 / (sse / 36))
